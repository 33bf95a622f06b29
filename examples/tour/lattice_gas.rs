//! lattice_gas: a small FHP channel flow past a disc (the source's scene at 256 x 128).

use std::path::Path;
use std::time::Instant;

use simkit::backend::{Backend, Result, Simulation};
use simkit::lattice_gas::{BlockField, TimeAverage};
use simkit::lattice_gas::{Config, CpuMethod, Lattice, LatticeGas, Obstacle, ROW_SPACING, RuleSet};

use crate::Row;

/// 256 x 128 channel (wall rows, a disc, inflow and outflow columns), 1200 steps of the
/// source's full collision table; writes `velocity.png` (8 x 8 blocks averaged over the last
/// 400 steps) and `velocity.vti`; checks that the scene is bit-identical to the portable
/// (scalar) CPU lookup-table backend.
pub fn run(backend: Backend<'_>, out: &Path) -> Result<Row> {
    let (w, h) = (256usize, 128usize);
    let (steps, average_from, every) = (1200u32, 800u32, 20u32);
    let mut lattice = Lattice::new(w, h)?;
    lattice.add_wall_rows();
    let channel = h as f64 * ROW_SPACING;
    lattice.add_obstacle(&Obstacle::Disc {
        cx: 0.25 * w as f64,
        cy: 0.5 * channel,
        radius: channel / 10.0,
    })?;
    lattice.fill_with(3, |_, _, k| if k == 0 { 0.5 } else { 0.15 })?;
    let config = Config {
        periodic_x: false,
        periodic_y: false,
        inflow: true,
        outflow: true,
        seed: 2026,
        // The source's collision table.
        rules: RuleSet::Full,
        ..Config::default()
    };
    let mut sim = LatticeGas::new(lattice.clone(), &config, backend)?;
    let t = Instant::now();
    sim.step(average_from)?;
    let mut avg = TimeAverage::new();
    for _ in 0..(steps - average_from) / every {
        sim.step(every)?;
        avg.add(&BlockField::from_lattice(&sim.state()?, 8)?)?;
    }
    let secs = t.elapsed().as_secs_f64();
    let field = avg.field().expect("samples were added");
    simkit::files::write_block_velocity_png(
        field,
        &out.join("velocity.png"),
        "FHP channel, 8x8 blocks",
    )?;
    simkit::files::write_block_field_vti(field, &out.join("velocity.vti"))?;
    let (ux, _) = field.velocity();
    let mean_ux = ux.iter().sum::<f64>() / ux.len() as f64;
    // The portable scalar lookup table: another code path than any backend above.
    let portable = Config {
        cpu: CpuMethod::LutPortable,
        ..config.clone()
    };
    let mut reference = LatticeGas::new(lattice, &portable, Backend::Cpu)?;
    reference.step(steps)?;
    let same = reference.state()? == sim.state()?;
    Ok(Row {
        scene: format!("lattice_gas: FHP channel {w}x{h}"),
        backend: sim.backend_name(),
        steps: u64::from(steps),
        throughput: (w * h) as f64 * f64::from(steps) / secs,
        unit: "site updates/s",
        check: format!(
            "mean u_x {mean_ux:.3}; bit-identical to cpu-lut (scalar): {}",
            if same { "yes" } else { "NO" }
        ),
    })
}
