//! Minimal raster drawing on [`RgbImage`]: pixels, rectangles, lines, discs. Everything is
//! clipped to the image, so any coordinates are safe.

use image::{Rgb, RgbImage};

/// Sets pixel `(x, y)` if it lies inside the image.
pub fn put(img: &mut RgbImage, x: i64, y: i64, color: [u8; 3]) {
    if x >= 0 && y >= 0 && x < img.width() as i64 && y < img.height() as i64 {
        img.put_pixel(x as u32, y as u32, Rgb(color));
    }
}

/// Fills the `w` x `h` rectangle with top-left corner `(x, y)`.
pub fn fill_rect(img: &mut RgbImage, x: i64, y: i64, w: i64, h: i64, color: [u8; 3]) {
    let x0 = x.max(0);
    let y0 = y.max(0);
    let x1 = x.saturating_add(w).min(img.width() as i64);
    let y1 = y.saturating_add(h).min(img.height() as i64);
    for py in y0..y1 {
        for px in x0..x1 {
            img.put_pixel(px as u32, py as u32, Rgb(color));
        }
    }
}

/// Draws the one-pixel outline of the `w` x `h` rectangle with top-left corner `(x, y)`.
pub fn stroke_rect(img: &mut RgbImage, x: i64, y: i64, w: i64, h: i64, color: [u8; 3]) {
    if w <= 0 || h <= 0 {
        return;
    }
    fill_rect(img, x, y, w, 1, color);
    fill_rect(img, x, y.saturating_add(h - 1), w, 1, color);
    fill_rect(img, x, y, 1, h, color);
    fill_rect(img, x.saturating_add(w - 1), y, 1, h, color);
}

/// Fills a disc of radius `r` pixels centred on `(cx, cy)`.
pub fn fill_disc(img: &mut RgbImage, cx: f64, cy: f64, r: f64, color: [u8; 3]) {
    if !(cx.is_finite() && cy.is_finite() && r.is_finite()) || r < 0.0 {
        return;
    }
    let (w, h) = (img.width() as f64, img.height() as f64);
    let x0 = (cx - r).floor().max(0.0);
    let x1 = (cx + r).ceil().min(w - 1.0);
    let y0 = (cy - r).floor().max(0.0);
    let y1 = (cy + r).ceil().min(h - 1.0);
    let mut y = y0;
    while y <= y1 {
        let mut x = x0;
        while x <= x1 {
            let (dx, dy) = (x + 0.5 - (cx + 0.5), y + 0.5 - (cy + 0.5));
            if dx * dx + dy * dy <= r * r + 0.25 {
                img.put_pixel(x as u32, y as u32, Rgb(color));
            }
            x += 1.0;
        }
        y += 1.0;
    }
}

/// Draws a line from `(x0, y0)` to `(x1, y1)` (pixel coordinates, pixel centres at
/// integers) with a square pen `width` pixels wide, clipped to the rectangle
/// `clip = [xmin, ymin, xmax, ymax]` (inclusive) and to the image.
#[allow(clippy::too_many_arguments)]
pub fn line_clipped(
    img: &mut RgbImage,
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
    width: u32,
    color: [u8; 3],
    clip: [i64; 4],
) {
    let clip = [
        clip[0].max(0),
        clip[1].max(0),
        clip[2].min(img.width() as i64 - 1),
        clip[3].min(img.height() as i64 - 1),
    ];
    if clip[0] > clip[2] || clip[1] > clip[3] {
        return;
    }
    let Some((ax, ay, bx, by)) = clip_segment(x0, y0, x1, y1, clip) else {
        return;
    };
    let (mut x, mut y) = (ax.round() as i64, ay.round() as i64);
    let (ex, ey) = (bx.round() as i64, by.round() as i64);
    let dx = (ex - x).abs();
    let dy = -(ey - y).abs();
    let sx = if x < ex { 1 } else { -1 };
    let sy = if y < ey { 1 } else { -1 };
    let mut err = dx + dy;
    let w = width.max(1) as i64;
    let lo = -(w - 1) / 2;
    let hi = lo + w;
    loop {
        // The pen square around (x, y), cut to the clip rectangle (a pen wider than the
        // image costs no more than the image).
        for py in (y + lo).max(clip[1])..(y + hi).min(clip[3] + 1) {
            for px in (x + lo).max(clip[0])..(x + hi).min(clip[2] + 1) {
                img.put_pixel(px as u32, py as u32, Rgb(color));
            }
        }
        if x == ex && y == ey {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}

/// Draws a line clipped only to the image (see [`line_clipped`]).
pub fn line(img: &mut RgbImage, x0: f64, y0: f64, x1: f64, y1: f64, width: u32, color: [u8; 3]) {
    let clip = [0, 0, img.width() as i64 - 1, img.height() as i64 - 1];
    line_clipped(img, x0, y0, x1, y1, width, color, clip);
}

/// Liang-Barsky clipping of a segment to a rectangle (padded by half a pixel).
fn clip_segment(x0: f64, y0: f64, x1: f64, y1: f64, r: [i64; 4]) -> Option<(f64, f64, f64, f64)> {
    if !(x0.is_finite() && y0.is_finite() && x1.is_finite() && y1.is_finite()) {
        return None;
    }
    let (xmin, ymin) = (r[0] as f64 - 0.49, r[1] as f64 - 0.49);
    let (xmax, ymax) = (r[2] as f64 + 0.49, r[3] as f64 + 0.49);
    let (dx, dy) = (x1 - x0, y1 - y0);
    let mut t0: f64 = 0.0;
    let mut t1: f64 = 1.0;
    for (p, q) in [
        (-dx, x0 - xmin),
        (dx, xmax - x0),
        (-dy, y0 - ymin),
        (dy, ymax - y0),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    Some((x0 + t0 * dx, y0 + t0 * dy, x0 + t1 * dx, y0 + t1 * dy))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count(img: &RgbImage) -> usize {
        img.pixels().filter(|p| p.0 != [0, 0, 0]).count()
    }

    #[test]
    fn lines_and_clipping() {
        let mut img = RgbImage::new(20, 10);
        line(&mut img, 0.0, 0.0, 19.0, 0.0, 1, [255, 0, 0]);
        assert_eq!(count(&img), 20);
        let mut img = RgbImage::new(20, 10);
        line(&mut img, -1e12, 5.0, 1e12, 5.0, 1, [255, 0, 0]);
        assert_eq!(count(&img), 20);
        let mut img = RgbImage::new(20, 10);
        line(&mut img, 0.0, 0.0, 9.0, 9.0, 1, [255, 0, 0]);
        assert_eq!(count(&img), 10);
        line(&mut img, f64::NAN, 0.0, 9.0, 9.0, 1, [255, 0, 0]);
        line(&mut img, 50.0, 50.0, 60.0, 60.0, 3, [255, 0, 0]);
        assert_eq!(count(&img), 10);
        fill_disc(&mut img, 15.0, 5.0, 2.0, [0, 255, 0]);
        assert!(count(&img) > 10);
        fill_rect(&mut img, -5, -5, 100, 100, [1, 1, 1]);
        assert_eq!(count(&img), 200);
    }
}
