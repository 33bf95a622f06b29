//! rd: a short bacterial-colony run (the source's scene scaled to 128 x 128).

use std::path::Path;
use std::time::Instant;

use simkit::backend::{Backend, Result, Simulation};
use simkit::output::heatmap::{HeatmapOptions, write_heatmap};
use simkit::rd::scenes::colony_scene;
use simkit::rd::{Config, Rd, Stepping};

use crate::Row;

/// 128 x 128 colony scene, 3000 Euler steps in f32; writes `b.png`; checks that b + n
/// (conserved by the model: the reaction moves n into b, the fluxes only move things) holds.
pub fn run(backend: Backend<'_>, out: &Path) -> Result<Row> {
    let n = 128;
    let steps: u32 = 3000; // a multiple of 30 (progress pieces)
    let (grid, model) = colony_scene::<f32>(n, n, 7)?;
    let start = grid.total(0) + grid.total(1);
    let b0 = grid.total(0);
    let mut sim = Rd::new(grid, model, &Config::new(Stepping::euler(0.005)), backend)?;
    let bar = crate::progress::bar("rd", u64::from(steps), "steps");
    let t = Instant::now();
    // In 30 pieces for the progress bar (the same result as one call).
    for _ in 0..30 {
        sim.step(steps / 30)?;
        bar.inc(u64::from(steps / 30));
    }
    let g = sim.state()?;
    let secs = t.elapsed().as_secs_f64();
    bar.finish_and_clear();
    write_heatmap(
        out.join("b.png"),
        g.field(0),
        n,
        n,
        &HeatmapOptions::new()
            .upscale(4)
            .title("bacterial colony: bacteria density b")
            .subtitle(format!("t = {:.0} time units", sim.time()))
            .x_label("x (cells)")
            .y_label("y (cells)")
            .quantity("b (density)"),
    )?;
    let drift = (g.total(0) + g.total(1) - start).abs() / start;
    Ok(Row {
        scene: "rd: bacterial colony 128^2".into(),
        backend: sim.backend_name(),
        steps: u64::from(steps),
        throughput: (n * n) as f64 * f64::from(steps) / secs,
        unit: "cell updates/s",
        check: format!(
            "total b {:.1} -> {:.1}; b + n drift {drift:.1e} (f32, want < 1e-5)",
            b0,
            g.total(0)
        ),
    })
}
