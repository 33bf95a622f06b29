//! PNG heat maps of 2D scalar fields, with a labelled colour bar and an optional title.
//!
//! Data is row-major: `data[row * width + col]`. By default row 0 is drawn at the bottom
//! (physics convention, y up); [`HeatmapOptions::row0_at_top`] flips that for image-style
//! data. NaN cells are drawn in [`NAN_COLOR`](crate::colormap::NAN_COLOR).

use std::path::Path;

use image::{Rgb, RgbImage};

use crate::colormap::Colormap;
use crate::{font, numfmt, png, raster};
use simkit_backend::{Error, Result};

/// Largest image side in pixels this crate renders.
pub const MAX_SIDE: usize = 32_768;

/// Largest image area in pixels this crate renders (2^27: 384 MiB of RGB); a larger image
/// is refused before it is allocated.
pub const MAX_PIXELS: usize = 1 << 27;

const WHITE: [u8; 3] = [255, 255, 255];
const BLACK: [u8; 3] = [0, 0, 0];

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
    /// Each grid cell becomes an `upscale` x `upscale` pixel block (default 1).
    pub upscale: u32,
    /// Draw a colour bar labelled with min and max on the right (default true).
    pub colorbar: bool,
    /// Title drawn above the field.
    pub title: Option<String>,
    /// Text scale factor; `None` (default) picks 1 or 2 from the image size.
    pub text_scale: Option<u32>,
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
            text_scale: None,
        }
    }
}

impl HeatmapOptions {
    /// The defaults: viridis, automatic range, row 0 at the bottom, no upscaling, colour bar,
    /// no title.
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
    /// Sets the text scale factor (>= 1). Text, colour bar and margins grow with it, and
    /// rendering refuses a scale that takes the image past [`MAX_SIDE`] pixels per side or
    /// [`MAX_PIXELS`] in all.
    pub fn text_scale(mut self, scale: u32) -> Self {
        self.text_scale = Some(scale);
        self
    }
}

/// Where the field itself sits in a rendered image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldPlacement {
    /// Left edge of the field in pixels.
    pub x0: u32,
    /// Top edge of the field in pixels.
    pub y0: u32,
    /// Pixels per grid cell.
    pub scale: u32,
}

/// Renders `data` (`width` x `height`, row-major) to an image; returns it and the value range
/// used. Use this to collect frames for [`crate::gif`].
///
/// Errors on zero sizes, `data.len() != width * height`, a zero upscale or text scale, an
/// image (field plus text, colour bar and margins) over [`MAX_SIDE`] per side or
/// [`MAX_PIXELS`] in all (checked before it is allocated; the error names `text_scale` when
/// one is set), a fixed range that is non-finite or has `min >= max`, or (automatic range)
/// data with no finite value.
pub fn render_heatmap<T: Copy + Into<f64>>(
    data: &[T],
    width: usize,
    height: usize,
    opts: &HeatmapOptions,
) -> Result<(RgbImage, (f64, f64))> {
    let values: Vec<f64> = data.iter().map(|&v| v.into()).collect();
    let (img, range, _) = render_field(&values, width, height, opts)?;
    Ok((img, range))
}

/// Renders like [`render_heatmap`] and writes the PNG atomically to `path`; returns the value
/// range used.
pub fn write_heatmap<T: Copy + Into<f64>>(
    path: impl AsRef<Path>,
    data: &[T],
    width: usize,
    height: usize,
    opts: &HeatmapOptions,
) -> Result<(f64, f64)> {
    let (img, range) = render_heatmap(data, width, height, opts)?;
    png::write_png(path, &img)?;
    Ok(range)
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

/// Renders the field, colour bar and title; also returns where the field was placed.
pub(crate) fn render_field(
    values: &[f64],
    width: usize,
    height: usize,
    opts: &HeatmapOptions,
) -> Result<(RgbImage, (f64, f64), FieldPlacement)> {
    check_grid("data", values.len(), width, height)?;
    if opts.upscale == 0 {
        return Err(Error::invalid(
            "upscale",
            0,
            "must be >= 1 (1 = one pixel per cell)",
        ));
    }
    if opts.text_scale == Some(0) {
        return Err(Error::invalid("text_scale", 0, "must be >= 1"));
    }
    let s = opts.upscale as usize;
    let (fw, fh) = (width.saturating_mul(s), height.saturating_mul(s));
    if fw > MAX_SIDE || fh > MAX_SIDE {
        return Err(Error::invalid(
            "upscale",
            opts.upscale,
            format!(
                "the field would be {fw} x {fh} pixels, over the limit of {MAX_SIDE}; use a \
                 smaller upscale"
            ),
        ));
    }
    let range = resolve_range(values, opts)?;
    let (fw, fh) = (fw as u32, fh as u32);
    let ts = opts
        .text_scale
        .unwrap_or(if fh.max(fw) >= 300 { 2 } else { 1 });
    // The layout in u64 (text widths saturate at u32::MAX), so that a huge text scale or
    // title is measured without overflow and refused below before anything is allocated.
    let t = u64::from(ts);
    let decorated = opts.colorbar || opts.title.is_some();
    let m = if decorated { 4 * t } else { 0 };
    let th = font::text_height(ts);
    let title_h = if opts.title.is_some() {
        u64::from(th) + m
    } else {
        0
    };
    let content_h = if opts.colorbar {
        u64::from(fh).max(2 * u64::from(th) + 4 * t)
    } else {
        u64::from(fh)
    };
    let (min_label, max_label) = (numfmt::short(range.0), numfmt::short(range.1));
    let bar_w = 10 * t;
    let bar_x = m + u64::from(fw) + 2 * m;
    let label_x = bar_x + bar_w + m;
    let label_w = font::text_width(&min_label, ts).max(font::text_width(&max_label, ts));
    let mut canvas_w = if opts.colorbar {
        label_x + u64::from(label_w) + m
    } else {
        u64::from(fw) + 2 * m
    };
    let title_w = opts
        .title
        .as_ref()
        .map_or(0, |title| u64::from(font::text_width(title, ts)) + 2 * m);
    canvas_w = canvas_w.max(title_w);
    let canvas_h = m + title_h + content_h + m;
    let limit = MAX_SIDE as u64;
    let too_large =
        |w: u64, h: u64| w > limit || h > limit || w.saturating_mul(h) > MAX_PIXELS as u64;
    if too_large(canvas_w, canvas_h) {
        let reason = format!(
            "the image would be {canvas_w} x {canvas_h} pixels (the field, plus text, colour \
             bar and margins that grow with the text scale), over the limit of {MAX_SIDE} \
             pixels per side and {MAX_PIXELS} pixels in all"
        );
        return Err(if let Some(scale) = opts.text_scale {
            Error::invalid(
                "text_scale",
                scale,
                format!("{reason}; use a smaller text_scale"),
            )
        } else if title_w > limit {
            Error::invalid(
                "title",
                format!(
                    "{} characters",
                    opts.title.as_deref().unwrap_or("").chars().count()
                ),
                format!("{reason}; use a shorter title"),
            )
        } else {
            Error::invalid(
                "upscale",
                opts.upscale,
                format!(
                    "{reason}; use a smaller upscale, drop the colour bar and title, or \
                     downsample the field"
                ),
            )
        });
    }
    // Each of these is at most the canvas size, so it fits a u32.
    let [
        m,
        title_h,
        content_h,
        bar_w,
        bar_x,
        label_x,
        canvas_w,
        canvas_h,
    ] = [
        m, title_h, content_h, bar_w, bar_x, label_x, canvas_w, canvas_h,
    ]
    .map(|v| v as u32);
    let mut img = RgbImage::from_pixel(canvas_w, canvas_h, Rgb(WHITE));
    let (x0, y0) = (m, m + title_h);

    // Field: colour per cell, then blocks.
    for r in 0..height {
        let row = if opts.row0_at_top { r } else { height - 1 - r };
        let py = y0 + (r * s) as u32;
        for c in 0..width {
            let color = opts
                .colormap
                .map_range(values[row * width + c], range.0, range.1);
            let px = x0 + (c * s) as u32;
            for dy in 0..s as u32 {
                for dx in 0..s as u32 {
                    img.put_pixel(px + dx, py + dy, Rgb(color));
                }
            }
        }
    }

    if let Some(t) = &opts.title {
        let tx = (canvas_w - font::text_width(t, ts)) / 2;
        font::draw_text(&mut img, tx as i64, m as i64, t, ts, BLACK);
    }

    if opts.colorbar {
        let denom = (content_h - 1).max(1) as f64;
        for y in 0..content_h {
            let t = 1.0 - y as f64 / denom;
            let color = opts.colormap.map(t);
            raster::fill_rect(
                &mut img,
                bar_x as i64,
                (y0 + y) as i64,
                bar_w as i64,
                1,
                color,
            );
        }
        raster::stroke_rect(
            &mut img,
            bar_x as i64 - 1,
            y0 as i64 - 1,
            bar_w as i64 + 2,
            content_h as i64 + 2,
            BLACK,
        );
        font::draw_text(&mut img, label_x as i64, y0 as i64, &max_label, ts, BLACK);
        let min_y = (y0 + content_h - th) as i64;
        font::draw_text(&mut img, label_x as i64, min_y, &min_label, ts, BLACK);
    }
    Ok((
        img,
        range,
        FieldPlacement {
            x0,
            y0,
            scale: s as u32,
        },
    ))
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
    fn orientation() {
        // 1 x 2 grid: row 0 = 0.0 (min), row 1 = 1.0 (max).
        let o = HeatmapOptions::new().colorbar(false);
        let (img, _) = render_heatmap(&[0.0, 1.0], 1, 2, &o).unwrap();
        assert_eq!(img.get_pixel(0, 1).0, Colormap::Viridis.map(0.0));
        let (img, _) = render_heatmap(&[0.0, 1.0], 1, 2, &o.row0_at_top(true)).unwrap();
        assert_eq!(img.get_pixel(0, 0).0, Colormap::Viridis.map(0.0));
    }
}
