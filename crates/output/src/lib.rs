//! Outputs shared by every simkit example: PNG heat maps, vector fields and line plots,
//! animated GIF, VTK (`.vti` image data, `.vtu` particles), extended XYZ and CSV time series.
//! (Progress bars: the examples use `indicatif`.)
//!
//! Every file is written atomically through [`atomic::write_atomic`] (temporary file in the
//! same directory, flush, sync, rename), so a crash or an error never leaves a half-written
//! output, and parent directories are created as needed. Errors are
//! [`simkit_backend::Error`] values whose messages name the bad value and the fix.
//!
//! | module | what it writes |
//! |---|---|
//! | [`heatmap`] | PNG of a 2D scalar field with colour bar and title |
//! | [`vector_field`] | PNG of a 2D vector field: magnitude plus arrows |
//! | [`plot`] | line and scatter plots, linear or log axes, legend |
//! | [`gif`] | animated GIF from RGB frames |
//! | [`vtk`] | ParaView files: `.vti` image data, `.vtu` particles, `.pvd` series |
//! | [`xyz`] | extended XYZ trajectories (OVITO) |
//! | [`csv`] | CSV time series |
//! | [`colormap`], [`font`], [`raster`], [`numfmt`], [`png`], [`atomic`] | building blocks |
//!
//! ```
//! use simkit_output::heatmap::{write_heatmap, HeatmapOptions};
//! # fn main() -> simkit_backend::Result<()> {
//! let (w, h) = (32, 24);
//! let field: Vec<f64> = (0..w * h).map(|i| ((i % w) as f64 * 0.3).sin()).collect();
//! let path = std::env::temp_dir().join("simkit-doc-heatmap").join("field.png");
//! let opts = HeatmapOptions::new().upscale(4).title("sin(0.3 x)");
//! let (min, max) = write_heatmap(&path, &field, w, h, &opts)?;
//! assert!(min >= -1.0 && max <= 1.0 && path.exists());
//! # Ok(())
//! # }
//! ```

pub mod atomic;
pub mod colormap;
pub mod csv;
pub mod font;
pub mod gif;
pub mod heatmap;
pub mod numfmt;
pub mod plot;
pub mod png;
pub mod raster;
pub mod vector_field;
pub mod vtk;
pub mod xyz;

pub use atomic::{AtomicFile, write_atomic};
pub use colormap::Colormap;
pub use image::RgbImage;
