//! dem: a small 2D vibrated bed (the source's chapter 1 scene, 128 discs, Gamma = 3 at
//! 20 Hz, contact time 5e-4 s instead of 5e-5 s so that a cycle takes 3000 steps).

use std::path::Path;
use std::time::Instant;

use simkit::backend::{Backend, Error, Result, Simulation};
use simkit::dem::scenes::{BedParams, vibrating_bed};
use simkit::dem::{Config, Dem};
use simkit::output::particles::ParticleFrame;

use crate::Row;

/// Two vibration cycles; writes `bed.png` (discs coloured by speed); checks that the bed
/// stays finite, inside the box, with small overlaps, and is lifted by the vibration.
pub fn run(backend: Backend<'_>, out: &Path) -> Result<Row> {
    let params = BedParams {
        n: 128,
        width: 16,
        contact_time_s: 5e-4,
        ..BedParams::default()
    };
    let (scene, _) = vibrating_bed(&params)?;
    let mut sim = Dem::new(scene.clone(), &Config::default(), backend)?;
    let rest = sim.diagnostics()?.com_height;
    let per_cycle = (2.0 * std::f64::consts::PI / sim.dt()).round() as u32;
    let cycles = 2;
    let t = Instant::now();
    let samples = 16;
    let (mut com, mut worst) = (0.0, 0.0f64);
    let bar = crate::progress::bar(
        "dem",
        u64::from(cycles * samples * (per_cycle / samples)),
        "steps",
    );
    for _ in 0..cycles * samples {
        sim.step(per_cycle / samples)?;
        bar.inc(u64::from(per_cycle / samples));
        let d = sim.diagnostics()?;
        if !d.finite {
            return Err(Error::invalid("dem tour state", "NaN", "the bed blew up"));
        }
        com += d.com_height / f64::from(cycles * samples);
        worst = worst.max(d.max_overlap_ratio);
    }
    let secs = t.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let s = sim.state()?;
    let (lo, hi) = (scene.lo(), scene.hi());
    let inside = s
        .positions
        .iter()
        .all(|p| p[0] > lo[0] && p[0] < hi[0] && p[1] > lo[1] - 1.0 && p[1] < hi[1] + 1.0);
    let pos: Vec<[f64; 2]> = s.positions.iter().map(|x| [x[0], x[1]]).collect();
    let radii: Vec<f64> = scene.particles().iter().map(|p| p.radius).collect();
    let speed: Vec<f64> = s.velocities.iter().map(|v| v[0].hypot(v[1])).collect();
    std::fs::create_dir_all(out).map_err(|e| simkit::output::atomic::io_error(out, &e))?;
    ParticleFrame::new(&pos, &radii)
        .bounds(lo[0], hi[0], lo[1], hi[1])
        .by_value(&speed, "|v| (d ω)")
        .range(0.0, 0.6)
        .title("vibrated bed")
        .subtitle(format!("t = {:.1} / ω", s.time))
        .x_label("x (grain diameters d)")
        .y_label("z (d)")
        .write(out.join("bed.png"))?;
    let steps = sim.steps_done();
    Ok(Row {
        scene: "dem: vibrated bed, 128 discs".into(),
        backend: sim.backend_name(),
        steps,
        throughput: params.n as f64 * steps as f64 / secs,
        unit: "particle-steps/s",
        check: format!(
            "COM height {com:.2} (at rest {rest:.2}); max overlap {:.1e} R; {}",
            worst,
            if inside {
                "all discs in the box"
            } else {
                "A DISC LEFT THE BOX"
            }
        ),
    })
}
