//! Files from simulation results: the glue between a simulation crate's observables and the
//! `output` writers, kept here so that the simulation crates write no files and `output`
//! depends on no simulation crate.

use std::path::Path;

use crate::backend::Result;
use crate::lattice_gas::observables::BlockField;
use crate::output::heatmap::HeatmapOptions;
use crate::output::vector_field::{VectorFieldOptions, write_vector_field};
use crate::output::vtk::ImageData;

/// The velocity of a lattice-gas block field as a PNG: magnitude colour map with arrows, on
/// physically square cells ([`BlockField::velocity_square_cells`]), about 768 pixels wide.
pub fn write_block_velocity_png(field: &BlockField, path: &Path, title: &str) -> Result<()> {
    let (ux, uy, cols, rows) = field.velocity_square_cells();
    let scale = (768 / cols.max(rows)).clamp(1, 32) as u32;
    let opts =
        VectorFieldOptions::new().background(HeatmapOptions::new().upscale(scale).title(title));
    write_vector_field(path, &ux, &uy, cols, rows, &opts)?;
    Ok(())
}

/// Density and velocity of a lattice-gas block field as VTK image data (`.vti`): one point per
/// block at the block centre, in lattice units ([`BlockField::block_geometry`]).
pub fn write_block_field_vti(field: &BlockField, path: &Path) -> Result<()> {
    let (origin, spacing) = field.block_geometry();
    let mut img = ImageData::new_2d(field.nx, field.ny, origin, spacing)?;
    let (ux, uy) = field.velocity();
    let vel: Vec<f64> = ux
        .iter()
        .zip(&uy)
        .flat_map(|(&x, &y)| [x, y, 0.0])
        .collect();
    img.add_scalar("density", &field.density())?;
    img.add_vector("velocity", &vel, 3)?;
    img.write(path)?;
    Ok(())
}
