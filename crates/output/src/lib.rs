//! Outputs shared by every simkit example: figures (heat maps, vector fields, particle
//! frames, line plots; PNG or SVG), animated GIF, VTK (`.vti` image data, `.vtp`
//! particles), extended XYZ and CSV time series.
//! (Progress bars: the examples use `indicatif`.)
//!
//! Every file is written atomically through [`atomic::write_atomic`] (temporary file in the
//! same directory, flush, sync, rename), so a crash or an error never leaves a half-written
//! output, and parent directories are created as needed. (GSD trajectories are appended
//! to in place, in an order that keeps every completed frame readable: see [`gsd`].) Errors are
//! [`simkit_backend::Error`] values whose messages name the bad value and the fix.
//!
//! | module | what it writes |
//! |---|---|
//! | [`heatmap`] | PNG/SVG of a 2D scalar field: spatial axes, labelled colour bar, title |
//! | [`vector_field`] | PNG/SVG of a 2D vector field: magnitude plus arrows |
//! | [`particles`] | PNG/SVG of 2D particle frames: discs by value (colour bar) or species (legend) |
//! | [`plot`] | line and scatter plots, linear or log axes, legend |
//! | [`gif`] | animated GIF from RGB frames |
//! | [`vtk`] | ParaView files: `.vti` image data, `.vtp` particles, `.pvd` series |
//! | [`xyz`] | extended XYZ trajectories (ASE, OVITO) |
//! | [`gsd`] | GSD trajectories (HOOMD-blue's format: freud, OVITO, MDAnalysis), appended frame by frame |
//! | [`csv`] | CSV time series |
//! | [`figure`], [`colormap`], [`numfmt`], [`png`], [`atomic`] | building blocks |
//!
//! Figures are drawn with [`plotters`] and set in the embedded DejaVu Sans font (no system
//! fonts needed; Greek letters render). The file extension picks the format: `.png` for
//! quick looks, `.svg` for papers.
//!
//! ```
//! use simkit_output::heatmap::{write_heatmap, HeatmapOptions};
//! # fn main() -> simkit_backend::Result<()> {
//! let (w, h) = (32, 24);
//! let field: Vec<f64> = (0..w * h).map(|i| ((i % w) as f64 * 0.3).sin()).collect();
//! let path = std::env::temp_dir().join("simkit-doc-heatmap").join("field.png");
//! let opts = HeatmapOptions::new()
//!     .upscale(4)
//!     .title("sin(0.3 x)")
//!     .x_label("x (cells)")
//!     .y_label("y (cells)")
//!     .quantity("u (arbitrary units)");
//! let (min, max) = write_heatmap(&path, &field, w, h, &opts)?;
//! assert!(min >= -1.0 && max <= 1.0 && path.exists());
//! # Ok(())
//! # }
//! ```

pub mod atomic;
pub mod colormap;
pub mod csv;
pub mod figure;
pub mod gif;
pub mod gsd;
pub mod heatmap;
pub mod numfmt;
pub mod particles;
pub mod plot;
pub mod png;
pub mod vector_field;
pub mod vtk;
pub mod xyz;

pub use atomic::{AtomicFile, write_atomic};
pub use colormap::Colormap;
pub use image::RgbImage;
