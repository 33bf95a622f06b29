//! Colour maps from a scalar in `[0, 1]` to RGB.
//!
//! [`Colormap::Viridis`] is perceptually uniform with monotonically rising lightness (for
//! magnitudes, densities, concentrations); [`Colormap::Diverging`] runs blue - white - red
//! around the midpoint (for signed fields such as vorticity or charge); [`Colormap::Gray`]
//! is black to white. Inputs outside `[0, 1]` are clamped and NaN is drawn in
//! [`NAN_COLOR`] so that missing or broken values stay visible.

/// The colour drawn for NaN inputs: magenta, which no map here contains.
pub const NAN_COLOR: [u8; 3] = [255, 0, 255];

/// The standard 11 anchor colours of viridis, evenly spaced in `t`.
const VIRIDIS: [u32; 11] = [
    0x440154, 0x482475, 0x414487, 0x355f8d, 0x2a788e, 0x21918c, 0x22a884, 0x44bf70, 0x7ad151,
    0xbddf26, 0xfde725,
];

/// Blue - white - red anchors (ColorBrewer RdBu, reversed so that low is blue).
const DIVERGING: [u32; 7] = [
    0x2166ac, 0x67a9cf, 0xd1e5f0, 0xf7f7f7, 0xfddbc7, 0xef8a62, 0xb2182b,
];

const GRAY: [u32; 2] = [0x000000, 0xffffff];

/// A colour map; see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Colormap {
    /// Perceptually uniform dark purple - blue - green - yellow (the default).
    #[default]
    Viridis,
    /// Blue - white - red for signed data; `t = 0.5` is white.
    Diverging,
    /// Black to white.
    Gray,
}

impl Colormap {
    /// The colour for `t`, clamped to `[0, 1]`; NaN gives [`NAN_COLOR`].
    pub fn map(self, t: f64) -> [u8; 3] {
        let anchors: &[u32] = match self {
            Colormap::Viridis => &VIRIDIS,
            Colormap::Diverging => &DIVERGING,
            Colormap::Gray => &GRAY,
        };
        interpolate(anchors, t)
    }

    /// The colour for `value` on the range `[min, max]` (`min` maps to `map(0)`, `max` to
    /// `map(1)`), also for ranges wider than `f64::MAX` (e.g. `-1e308` to `1e308`). A
    /// degenerate range (`max <= min`, or an infinite end) maps everything to the middle
    /// colour.
    pub fn map_range(self, value: f64, min: f64, max: f64) -> [u8; 3] {
        if value.is_nan() {
            return NAN_COLOR;
        }
        let span = max - min;
        let t = if span > 0.0 && span.is_finite() {
            (value - min) / span
        } else if min.is_finite() && max.is_finite() && max > min {
            // The span passes f64::MAX: halving is exact and keeps it finite.
            (value / 2.0 - min / 2.0) / (max / 2.0 - min / 2.0)
        } else {
            0.5
        };
        self.map(t)
    }
}

/// Viridis at `t` (see [`Colormap::Viridis`]).
pub fn viridis(t: f64) -> [u8; 3] {
    Colormap::Viridis.map(t)
}

/// Blue - white - red at `t` (see [`Colormap::Diverging`]).
pub fn diverging(t: f64) -> [u8; 3] {
    Colormap::Diverging.map(t)
}

fn rgb(c: u32) -> [f64; 3] {
    [
        ((c >> 16) & 0xff) as f64,
        ((c >> 8) & 0xff) as f64,
        (c & 0xff) as f64,
    ]
}

fn interpolate(anchors: &[u32], t: f64) -> [u8; 3] {
    if t.is_nan() {
        return NAN_COLOR;
    }
    let t = t.clamp(0.0, 1.0);
    let segments = anchors.len() - 1;
    let x = t * segments as f64;
    let i = (x.floor() as usize).min(segments - 1);
    let f = x - i as f64;
    let (a, b) = (rgb(anchors[i]), rgb(anchors[i + 1]));
    let mut out = [0u8; 3];
    for k in 0..3 {
        out[k] = (a[k] + (b[k] - a[k]) * f).round().clamp(0.0, 255.0) as u8;
    }
    out
}

/// Relative luminance proxy (Rec. 709 weights on the sRGB values), in `[0, 255]`.
pub fn luminance(c: [u8; 3]) -> f64 {
    0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints_clamping_and_nan() {
        assert_eq!(viridis(0.0), [0x44, 0x01, 0x54]);
        assert_eq!(viridis(1.0), [0xfd, 0xe7, 0x25]);
        assert_eq!(viridis(0.5), [0x21, 0x91, 0x8c]);
        assert_eq!(viridis(-3.0), viridis(0.0));
        assert_eq!(viridis(7.0), viridis(1.0));
        assert_eq!(viridis(f64::NAN), NAN_COLOR);
        assert_eq!(diverging(0.5), [0xf7, 0xf7, 0xf7]);
        assert!(diverging(0.0)[2] > diverging(0.0)[0]); // blue end
        assert!(diverging(1.0)[0] > diverging(1.0)[2]); // red end
        assert_eq!(Colormap::Gray.map(1.0), [255, 255, 255]);
        assert_eq!(Colormap::Viridis.map_range(5.0, 0.0, 10.0), viridis(0.5));
        assert_eq!(Colormap::Viridis.map_range(f64::NAN, 0.0, 1.0), NAN_COLOR);
        // A range wider than f64::MAX used to map every value to the middle colour.
        let (lo, hi) = (-1e308, 1e308);
        assert_eq!(Colormap::Viridis.map_range(lo, lo, hi), viridis(0.0));
        assert_eq!(Colormap::Viridis.map_range(0.0, lo, hi), viridis(0.5));
        assert_eq!(Colormap::Viridis.map_range(hi, lo, hi), viridis(1.0));
    }

    #[test]
    fn viridis_lightness_rises() {
        let mut last = -1.0;
        for i in 0..=1000 {
            let l = luminance(viridis(i as f64 / 1000.0));
            assert!(
                l >= last - 0.75,
                "luminance falls at t = {}",
                i as f64 / 1000.0
            );
            last = l;
        }
        assert!(luminance(viridis(1.0)) > luminance(viridis(0.0)) + 150.0);
    }
}
