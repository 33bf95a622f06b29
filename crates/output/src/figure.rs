//! What every figure of this crate shares: the embedded font, the output format chosen from
//! the file extension (`.png` bitmap, `.svg` vector), the header (title and subtitle that
//! shrink to fit the width), numeric axes with readable tick labels, and the colour bar.
//!
//! Drawing is done with [`plotters`]: its bitmap backend renders into an RGB buffer (PNG
//! files and GIF frames), its SVG backend writes vector files for papers. Text is set in
//! DejaVu Sans, embedded in the crate (Bitstream Vera licence, `fonts/LICENSE-DejaVu.txt`),
//! so no system font is needed and Greek letters (`ω`, `ρ`, `σ`) render.

use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

use image::RgbImage;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, register_font};

use crate::colormap::Colormap;
use crate::{numfmt, png};
use simkit_backend::{Error, Result};

/// Largest image side in pixels this crate renders.
pub const MAX_SIDE: usize = 32_768;

/// Largest image area in pixels this crate renders (2^27: 384 MiB of RGB); a larger image
/// is refused before it is allocated.
pub const MAX_PIXELS: usize = 1 << 27;

/// The font family name under which the embedded DejaVu Sans is registered.
pub const FONT_FAMILY: &str = "sans-serif";

const FONT: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");

/// Font size of axis titles, legend entries and colour-bar titles, in pixels.
pub(crate) const LABEL_PX: f64 = 16.0;
/// Font size of tick labels, in pixels.
pub(crate) const TICK_PX: f64 = 14.0;
/// Largest font size of titles, in pixels (shrunk until the title fits).
pub(crate) const TITLE_PX: f64 = 22.0;

/// Registers the embedded font once; errors if it cannot be parsed (never with the file
/// shipped in the crate).
fn font_ready() -> Result<()> {
    static READY: OnceLock<bool> = OnceLock::new();
    if *READY.get_or_init(|| register_font(FONT_FAMILY, FontStyle::Normal, FONT).is_ok()) {
        Ok(())
    } else {
        Err(Error::Unsupported(
            "the embedded DejaVu Sans font could not be parsed; reinstall simkit-output".into(),
        ))
    }
}

/// The file formats figures are written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Bitmap (`.png`): quick looks, GIF frames.
    Png,
    /// Vector graphics (`.svg`): papers, lossless zoom.
    Svg,
}

impl Format {
    /// The format named by the extension of `path` (case-insensitive `png` or `svg`).
    ///
    /// Errors for any other or missing extension.
    pub fn from_path(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png") => Ok(Format::Png),
            Some("svg") => Ok(Format::Svg),
            _ => Err(Error::invalid(
                "figure path",
                path.display(),
                "the extension picks the format: end the file name in .png (bitmap) or .svg \
                 (vector)",
            )),
        }
    }
}

/// A figure that can be drawn on any plotters backend.
pub(crate) trait Figure {
    /// Image size in pixels (checked against [`MAX_SIDE`] and [`MAX_PIXELS`] before drawing).
    fn size(&self) -> (u32, u32);
    /// Draws the whole figure on `root` (already filled white).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>;
}

/// Turns a plotters drawing error into this crate's error.
pub(crate) fn draw_err<E: std::fmt::Debug>(e: E) -> Error {
    Error::Unsupported(format!("drawing the figure failed: {e:?}"))
}

fn check_size(what: &str, (w, h): (u32, u32)) -> Result<()> {
    let (wu, hu) = (w as usize, h as usize);
    if w == 0 || h == 0 || wu > MAX_SIDE || hu > MAX_SIDE || wu * hu > MAX_PIXELS {
        return Err(Error::invalid(
            format!("{what} size"),
            format!("{w} x {h} pixels"),
            format!(
                "a figure must have 1 to {MAX_SIDE} pixels per side and at most {MAX_PIXELS} \
                 pixels in all; use a smaller upscale or downsample the data"
            ),
        ));
    }
    Ok(())
}

/// Renders `fig` into an RGB image.
pub(crate) fn render_rgb(what: &str, fig: &impl Figure) -> Result<RgbImage> {
    font_ready()?;
    let (w, h) = fig.size();
    check_size(what, (w, h))?;
    let mut buf = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        fig.draw(&root)?;
        root.present().map_err(draw_err)?;
    }
    RgbImage::from_raw(w, h, buf).ok_or_else(|| draw_err("buffer size mismatch"))
}

/// Renders `fig` as SVG text.
pub(crate) fn render_svg(what: &str, fig: &impl Figure) -> Result<String> {
    font_ready()?;
    let size = fig.size();
    check_size(what, size)?;
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        fig.draw(&root)?;
        root.present().map_err(draw_err)?;
    }
    Ok(out)
}

/// Writes `fig` atomically as PNG or SVG, picked from the extension of `path`.
pub(crate) fn write_figure(what: &str, path: &Path, fig: &impl Figure) -> Result<()> {
    match Format::from_path(path)? {
        Format::Png => png::write_png(path, &render_rgb(what, fig)?),
        Format::Svg => {
            let svg = render_svg(what, fig)?;
            crate::atomic::write_atomic(path, |w| w.write_all(svg.as_bytes()))
        }
    }
}

/// The text style of the embedded font at `px` pixels.
pub(crate) fn font(px: f64) -> TextStyle<'static> {
    (FONT_FAMILY, px).into_font().color(&BLACK)
}

/// RGB triple as a plotters colour.
pub(crate) fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// Draws the title (shrunk until it fits the width, down to 9 px) and the subtitle centred
/// at the top of `root`; returns the area below them.
pub(crate) fn draw_header<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    subtitle: &str,
) -> Result<DrawingArea<DB, Shift>> {
    let (w, _) = root.dim_in_pixel();
    let room = w.saturating_sub(16);
    let mut y = 6i32;
    for (text, start) in [(title, TITLE_PX), (subtitle, LABEL_PX)] {
        if text.is_empty() {
            continue;
        }
        let mut px = start;
        let style = loop {
            let style = font(px);
            let (tw, _) = root.estimate_text_size(text, &style).map_err(draw_err)?;
            if tw <= room || px <= 9.0 {
                break style;
            }
            px = (px - 1.0).max(9.0);
        };
        let centred = style.pos(Pos::new(HPos::Center, VPos::Top));
        root.draw_text(text, &centred, ((w / 2) as i32, y))
            .map_err(draw_err)?;
        y += (px * 1.3).ceil() as i32;
    }
    Ok(root.margin(header_height(title, subtitle), 0, 0, 0))
}

/// The pixel height [`draw_header`] uses for a title and subtitle.
pub(crate) fn header_height(title: &str, subtitle: &str) -> u32 {
    let mut h = 6.0;
    if !title.is_empty() {
        h += (TITLE_PX * 1.3).ceil();
    }
    if !subtitle.is_empty() {
        h += (LABEL_PX * 1.3).ceil();
    }
    h as u32 + 4
}

/// Writes `text` bottom to top, centred on `(x, y)` (pixels of `area`): the title of a
/// y axis. (Drawn here rather than by the chart so that its left edge stays inside the
/// image.)
pub(crate) fn draw_y_title<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    (x, y): (i32, i32),
) -> Result<()> {
    if text.is_empty() {
        return Ok(());
    }
    let style = font(LABEL_PX)
        .transform(FontTransform::Rotate270)
        .pos(Pos::new(HPos::Center, VPos::Center));
    area.draw_text(text, &style, (x, y)).map_err(draw_err)
}

/// Axis scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scale {
    /// Linear axis (default).
    #[default]
    Linear,
    /// Base-10 logarithmic axis; every value on it must be > 0.
    Log10,
}

/// A numeric axis for plotters: the range and the ticks, in transformed coordinates (log10
/// of the values on a log axis). Its ticks are 1, 2 or 5 times a power of ten (whole decades
/// on log axes) and their labels carry just enough digits: values within a billionth of a
/// tick step of zero read `0`, not `-2.26e-50`. Ranges near `±f64::MAX` stay finite.
#[derive(Debug, Clone)]
pub(crate) struct Axis {
    pub(crate) scale: Scale,
    pub(crate) lo: f64,
    pub(crate) hi: f64,
    pub(crate) ticks: Vec<(f64, String)>,
}

impl Axis {
    /// `v` in the axis's coordinates.
    pub(crate) fn tf(&self, v: f64) -> f64 {
        match self.scale {
            Scale::Linear => v,
            Scale::Log10 => v.log10(),
        }
    }

    /// Where `t` (axis coordinates) lies, 0 at `lo` and 1 at `hi`.
    pub(crate) fn frac(&self, t: f64) -> f64 {
        let span = self.hi - self.lo;
        if span.is_finite() {
            (t - self.lo) / span
        } else {
            // The span passes f64::MAX (data near ±1e308): halving is exact and keeps it finite.
            (t / 2.0 - self.lo / 2.0) / (self.hi / 2.0 - self.lo / 2.0)
        }
    }

    /// An axis over the values (or over `fixed`), with about `target` ticks. With `exact`,
    /// the range is the data's (or `fixed`) range and is not rounded outward to a tick.
    pub(crate) fn build(
        name: &str,
        scale: Scale,
        fixed: Option<(f64, f64)>,
        values: impl Iterator<Item = f64>,
        target: usize,
        exact: bool,
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
        if !(min.is_finite() && max.is_finite()) {
            return Err(Error::invalid(
                format!("{name} values"),
                "none",
                "an axis needs at least one finite value or a fixed range",
            ));
        }
        let exact = exact || fixed.is_some();
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
                let (lo, hi) = if exact {
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
                } else if !exact {
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

impl Ranged for Axis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        // Clamped so that far-off points (a fixed range cutting the data) stay in i32.
        let f = self.frac(*value);
        let f = if f.is_nan() { 0.5 } else { f.clamp(-4.0, 5.0) };
        limit.0 + (f * f64::from(limit.1 - limit.0)).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        let n = self.ticks.len();
        let max = hint.max_num_points().max(1);
        let stride = n.div_ceil(max).max(1);
        self.ticks.iter().step_by(stride).map(|t| t.0).collect()
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

impl ValueFormatter<f64> for Axis {
    fn format_ext(&self, value: &f64) -> String {
        self.ticks
            .iter()
            .find(|t| t.0 == *value)
            .map_or_else(|| numfmt::short(*value), |t| t.1.clone())
    }
}

/// An axis over the spatial range `(a, b)` of a figure (`name` is `"extent x"`, ...):
/// finite, `a < b`, and `b - a` finite too, since positions inside are interpolated.
pub(crate) fn spatial_axis(name: &str, (a, b): (f64, f64)) -> Result<Axis> {
    if (b - a).is_infinite() {
        return Err(Error::invalid(
            name,
            format!("({a}, {b})"),
            "the span b - a passes f64::MAX; rescale the coordinates",
        ));
    }
    Axis::build(name, Scale::Linear, Some((a, b)), [].into_iter(), 6, true)
}

/// 1, 2 or 5 times a power of ten, at least `raw`.
pub(crate) fn nice_step(raw: f64) -> f64 {
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
pub(crate) fn linear_ticks(lo: f64, hi: f64, step: f64) -> Vec<f64> {
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

/// Width in pixels of the strip that [`draw_colorbar`] needs right of a plot.
pub(crate) const COLORBAR_W: u32 = 130;

/// Draws a vertical colour bar for `colormap` over `range` into `area` (a strip of width
/// [`COLORBAR_W`]), with ticks, tick labels and the quantity written along it. `top` and
/// `bottom` are the pixel margins that align the bar with the plot beside it.
pub(crate) fn draw_colorbar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    colormap: Colormap,
    range: (f64, f64),
    quantity: &str,
    top: u32,
    bottom: u32,
) -> Result<()> {
    let axis = Axis::build(
        "colour bar",
        Scale::Linear,
        Some(range),
        [].into_iter(),
        5,
        true,
    )?;
    let (w, h) = area.dim_in_pixel();
    let (x0, x1) = (14i32, 32i32);
    let (y_top, y_bot) = (top as i32, h as i32 - bottom as i32 - 1);
    let rows = (y_bot - y_top).max(1);
    // One band per pixel row, bottom (t = 0) to top (t = 1).
    for k in 0..=rows {
        let t = f64::from(k) / f64::from(rows);
        let y = y_bot - k;
        area.draw(&Rectangle::new(
            [(x0, y), (x1, y + 1)],
            rgb(colormap.map(t)).filled(),
        ))
        .map_err(draw_err)?;
    }
    let labels = font(TICK_PX).pos(Pos::new(HPos::Left, VPos::Center));
    for (v, label) in &axis.ticks {
        let y = y_bot - (axis.frac(*v) * f64::from(rows)).round() as i32;
        area.draw(&PathElement::new([(x1, y), (x1 + 5, y)], BLACK))
            .map_err(draw_err)?;
        area.draw_text(label, &labels, (x1 + 8, y))
            .map_err(draw_err)?;
    }
    draw_y_title(area, quantity, (w as i32 - 16, (y_top + y_bot) / 2))
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
    fn tiny_values_near_zero_read_zero() {
        // A colour bar from -2.26e-50 to 0.75: the bottom tick is 0, not -2.26e-50.
        let a = Axis::build(
            "c",
            Scale::Linear,
            Some((-2.26e-50, 0.75)),
            [].into_iter(),
            5,
            true,
        )
        .unwrap();
        assert_eq!(a.ticks[0].1, "0");
        assert!(
            a.ticks.iter().all(|t| !t.1.contains("e-50")),
            "{:?}",
            a.ticks
        );
    }

    #[test]
    fn ranges_near_f64_max_give_finite_ticks() {
        let ys = [-1e308, 1e308];
        let a = Axis::build("y", Scale::Linear, None, ys.into_iter(), 6, false).unwrap();
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
            let a = Axis::build("y", Scale::Linear, fixed, values.into_iter(), 6, false).unwrap();
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

    #[test]
    fn format_from_extension() {
        assert_eq!(
            Format::from_path(Path::new("a/b.PNG")).unwrap(),
            Format::Png
        );
        assert_eq!(Format::from_path(Path::new("b.svg")).unwrap(), Format::Svg);
        let e = Format::from_path(Path::new("b.jpg"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("b.jpg") && e.contains(".svg"), "{e}");
    }
}
