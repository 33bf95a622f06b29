//! Animated GIF from RGB frames (for example heat maps from
//! [`render_heatmap`](crate::heatmap::render_heatmap)), written atomically.
//!
//! ```
//! use simkit_output::gif::write_gif;
//! use simkit_output::heatmap::{render_heatmap, HeatmapOptions};
//! # fn main() -> simkit_backend::Result<()> {
//! let opts = HeatmapOptions::new().range(-1.0, 1.0).upscale(4);
//! let mut frames = Vec::new();
//! for step in 0..5 {
//!     let field: Vec<f64> = (0..256).map(|i| ((i + 10 * step) as f64 * 0.1).sin()).collect();
//!     frames.push(render_heatmap(&field, 16, 16, &opts)?.0);
//! }
//! let path = std::env::temp_dir().join("simkit-doc-gif").join("wave.gif");
//! write_gif(&path, &frames, 100)?;
//! # Ok(())
//! # }
//! ```

use std::io::{self, Write};
use std::path::Path;
use std::sync::{Arc, Mutex};

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, RgbImage};

use crate::atomic::AtomicFile;
use simkit_backend::{Error, Result};

/// The longest delay between frames a GIF can store, in milliseconds (65535 hundredths of a
/// second).
pub const MAX_DELAY_MS: u32 = 655_350;

/// Writes `frames` as a looping animated GIF with `delay_ms` between frames (stored in
/// hundredths of a second, rounded down).
///
/// Errors when there are no frames, frames differ in size, a frame is empty or larger than
/// 65535 pixels on a side, the delay is over [`MAX_DELAY_MS`], or on I/O failure (the
/// previous file is then left intact).
pub fn write_gif(path: impl AsRef<Path>, frames: &[RgbImage], delay_ms: u32) -> Result<()> {
    if frames.is_empty() {
        return Err(Error::invalid(
            "frames",
            "0 frames",
            "an animation needs at least one frame",
        ));
    }
    let mut w = GifWriter::create(path, delay_ms)?;
    for f in frames {
        w.push(f)?;
    }
    w.finish()
}

/// Shares the temporary file between the encoder and the writer that commits it.
#[derive(Clone)]
struct Sink(Arc<Mutex<AtomicFile>>);

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.0
            .lock()
            .map_err(|_| io::Error::other("poisoned lock"))?
            .write(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.0
            .lock()
            .map_err(|_| io::Error::other("poisoned lock"))?
            .flush()
    }
}

/// Streams frames into a GIF one at a time (no need to keep them all in memory); the file
/// appears atomically at [`finish`](Self::finish). Dropping without `finish` leaves no file.
pub struct GifWriter {
    encoder: Option<GifEncoder<Sink>>,
    sink: Sink,
    delay_ms: u32,
    size: Option<(u32, u32)>,
    frames: usize,
}

impl std::fmt::Debug for GifWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GifWriter")
            .field("delay_ms", &self.delay_ms)
            .field("size", &self.size)
            .field("frames", &self.frames)
            .finish()
    }
}

impl GifWriter {
    /// Starts a looping GIF at `path` with `delay_ms` between frames (stored in hundredths
    /// of a second, rounded down).
    ///
    /// Errors: a delay over [`MAX_DELAY_MS`], or a file that cannot be created.
    pub fn create(path: impl AsRef<Path>, delay_ms: u32) -> Result<Self> {
        if delay_ms > MAX_DELAY_MS {
            return Err(Error::invalid(
                "delay_ms",
                delay_ms,
                format!(
                    "a GIF stores at most {MAX_DELAY_MS} ms (65535 hundredths of a second) \
                     between frames; use a shorter delay"
                ),
            ));
        }
        let file = AtomicFile::create(path)?;
        let shown = file.path().display().to_string();
        let sink = Sink(Arc::new(Mutex::new(file)));
        let mut encoder = GifEncoder::new_with_speed(sink.clone(), 10);
        encoder
            .set_repeat(Repeat::Infinite)
            .map_err(|e| Error::Io {
                path: shown,
                message: e.to_string(),
            })?;
        Ok(Self {
            encoder: Some(encoder),
            sink,
            delay_ms,
            size: None,
            frames: 0,
        })
    }

    /// Number of frames pushed so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Appends a frame; all frames must have the size of the first.
    pub fn push(&mut self, frame: &RgbImage) -> Result<()> {
        let (w, h) = frame.dimensions();
        if w == 0 || h == 0 || w > u16::MAX as u32 || h > u16::MAX as u32 {
            return Err(Error::invalid(
                format!("frame[{}] size", self.frames),
                format!("{w} x {h}"),
                "GIF frames must be 1 to 65535 pixels on each side",
            ));
        }
        match self.size {
            None => self.size = Some((w, h)),
            Some((fw, fh)) if (fw, fh) != (w, h) => {
                return Err(Error::invalid(
                    format!("frame[{}] size", self.frames),
                    format!("{w} x {h}"),
                    format!(
                        "differs from the first frame ({fw} x {fh}); render every frame with \
                         the same options (fix the range so label widths do not change)"
                    ),
                ));
            }
            Some(_) => {}
        }
        let rgba = image::DynamicImage::ImageRgb8(frame.clone()).into_rgba8();
        let delay = Delay::from_numer_denom_ms(self.delay_ms, 1);
        let path = self.path_string();
        let encoder = self.encoder.as_mut().ok_or_else(|| Error::Io {
            path: path.clone(),
            message: "writer already finished".into(),
        })?;
        encoder
            .encode_frame(Frame::from_parts(rgba, 0, 0, delay))
            .map_err(|e| Error::Io {
                path,
                message: e.to_string(),
            })?;
        self.frames += 1;
        Ok(())
    }

    fn path_string(&self) -> String {
        self.sink
            .0
            .lock()
            .map(|f| f.path().display().to_string())
            .unwrap_or_default()
    }

    /// Writes the trailer and renames the file into place.
    pub fn finish(self) -> Result<()> {
        let path = self.path_string();
        if self.frames == 0 {
            return Err(Error::invalid(
                "frames",
                "0 frames",
                format!("push at least one frame before finishing {path}"),
            ));
        }
        let GifWriter { encoder, sink, .. } = self;
        drop(encoder); // writes the GIF trailer and releases its handle on the file
        let file = Arc::try_unwrap(sink.0)
            .map_err(|_| Error::Io {
                path: path.clone(),
                message: "encoder still holds the file".into(),
            })?
            .into_inner()
            .map_err(|_| Error::Io {
                path: path.clone(),
                message: "poisoned lock".into(),
            })?;
        file.commit()
    }
}
