//! PNG files from RGB images.

use std::io;
use std::path::Path;

use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{ExtendedColorType, ImageEncoder, RgbImage};

use crate::atomic::write_atomic;
use simkit_backend::Result;

/// Writes `img` as an 8-bit RGB PNG, atomically.
pub fn write_png(path: impl AsRef<Path>, img: &RgbImage) -> Result<()> {
    write_atomic(path, |w| {
        PngEncoder::new_with_quality(w, CompressionType::Fast, FilterType::Adaptive)
            .write_image(
                img.as_raw(),
                img.width(),
                img.height(),
                ExtendedColorType::Rgb8,
            )
            .map_err(io::Error::other)
    })
}
