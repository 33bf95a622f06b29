//! Files from simulation results: the glue between a simulation crate's observables and the
//! `output` writers, kept here so that the simulation crates write no files and `output`
//! depends on no simulation crate.

use std::path::Path;

use crate::backend::Result;
use crate::lattice_gas::BlockField;
use crate::output::heatmap::HeatmapOptions;
use crate::output::vector_field::{VectorFieldOptions, write_vector_field};
use crate::output::vtk::ImageData;

/// How [`write_block_velocity_png`] draws a block field: magnitude colour map with arrows on
/// physically square cells ([`BlockField::velocity_square_cells`]), about 768 pixels wide,
/// axes in lattice units, the colour bar labelled with the speed. Use it for GIF frames
/// too (`render_vector_field`).
pub fn block_velocity_options(field: &BlockField, title: &str) -> VectorFieldOptions {
    let (_, _, cols, rows) = field.velocity_square_cells();
    let scale = (768 / cols.max(rows)).clamp(1, 32) as u32;
    let (_, spacing) = field.block_geometry();
    let (nx, ny) = field.blocks();
    let (width, height) = (nx as f64 * spacing[0], ny as f64 * spacing[1]);
    VectorFieldOptions::new().background(
        HeatmapOptions::new()
            .upscale(scale)
            .title(title)
            .extent(0.0, width, 0.0, height)
            .x_label("x (lattice units)")
            .y_label("y (lattice units)")
            .quantity("|u| (lattice units per step)"),
    )
}

/// The velocity of a lattice-gas block field as a figure ([`block_velocity_options`]): PNG
/// for a `.png` path, SVG for `.svg`.
pub fn write_block_velocity_png(field: &BlockField, path: &Path, title: &str) -> Result<()> {
    let (ux, uy, cols, rows) = field.velocity_square_cells();
    let opts = block_velocity_options(field, title);
    write_vector_field(path, &ux, &uy, cols, rows, &opts)?;
    Ok(())
}

/// Density and velocity of a lattice-gas block field as VTK image data (`.vti`): one point per
/// block at the block centre, in lattice units ([`BlockField::block_geometry`]).
pub fn write_block_field_vti(field: &BlockField, path: &Path) -> Result<()> {
    let (origin, spacing) = field.block_geometry();
    let (nx, ny) = field.blocks();
    let mut img = ImageData::new_2d(nx, ny, origin, spacing)?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lattice_gas::Lattice;

    /// Width and height from a PNG's IHDR chunk (bytes 16..24, big-endian).
    fn png_size(bytes: &[u8]) -> (u32, u32) {
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "a PNG signature");
        let be = |i: usize| u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap());
        (be(16), be(20))
    }

    #[test]
    fn block_field_png_and_vti_are_written() {
        let mut l = Lattice::new(128, 64).unwrap();
        l.add_wall_rows();
        l.fill_with(4, |_, _, k| if k == 0 { 0.5 } else { 0.2 })
            .unwrap();
        let f = BlockField::from_lattice(&l, 8).unwrap();
        let (ux, _) = f.velocity();
        assert!(ux.iter().sum::<f64>() > 0.0, "east-movers dominate");
        let dir = tempfile::tempdir().unwrap();
        let (png, vti) = (dir.path().join("u.png"), dir.path().join("u.vti"));
        write_block_velocity_png(&f, &png, "test").unwrap();
        write_block_field_vti(&f, &vti).unwrap();
        // 16 x 8 blocks of 8 x 8 sites: 18 x 8 physically square cells, upscaled.
        let (w, h) = png_size(&std::fs::read(&png).unwrap());
        assert!(w >= 18 * 8 && h >= 8 * 8, "{w} x {h}");
        let text = std::fs::read_to_string(&vti).unwrap();
        assert!(text.contains("ImageData") && text.contains("velocity"));
        assert!(text.contains("density") && text.contains("WholeExtent=\"0 15 0 7 0 0\""));
    }
}
