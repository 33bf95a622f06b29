//! Tour scene: a small Lennard-Jones liquid (the `in.lj` state at 500 atoms) at constant
//! energy, with the drift of the total energy as the validation figure.

use std::path::Path;
use std::time::Instant;

use simkit::backend::{Backend, Result, Simulation};
use simkit::md::{Config, LennardJones, Md, PairTable, scenes};
use simkit::output::csv::write_csv;
use simkit::output::plot::{Plot, Series};

use crate::Row;

/// 5^3 FCC cells (500 atoms) at density 0.8442 and T = 1.44, cutoff 2.5 with the energy
/// shifted to 0 at the cutoff (so that pairs crossing it do not make the energy jump),
/// dt = 0.005, 600 steps (t = 3); energies per atom every 20 steps.
pub fn run(backend: Backend<'_>, out: &Path) -> Result<Row> {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    let system = scenes::fcc_lattice([5; 3], 0.8442, 1.44, table, &[0], 87287)?;
    let n = system.particle_count() as f64;
    let config = Config {
        shift: true,
        ..Config::default().with_dt(0.005)
    };
    let mut md = Md::new(system.clone(), &config, backend)?;
    let (steps, every) = (600u32, 20u32);
    let mut rows: Vec<[f64; 4]> = Vec::new();
    let d = md.diagnostics()?;
    rows.push([d.time, d.kinetic / n, d.potential / n, d.total / n]);
    let mut stepping = 0.0;
    for _ in 0..steps / every {
        let t = Instant::now();
        md.step(every)?;
        stepping += t.elapsed().as_secs_f64();
        let d = md.diagnostics()?;
        rows.push([d.time, d.kinetic / n, d.potential / n, d.total / n]);
    }
    write_csv(
        out.join("energy.csv"),
        &[
            "time",
            "kinetic_per_atom",
            "potential_per_atom",
            "total_per_atom",
        ],
        &rows,
    )?;
    let e0 = rows[0][3];
    // After the first 0.5 time units the lattice has melted; the drift is measured from
    // there, so that the fast relaxation of the start does not count.
    let settled = rows.iter().position(|r| r[0] >= 0.5).unwrap_or(0);
    let (lo, hi) = rows[settled..]
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
            (lo.min(r[3]), hi.max(r[3]))
        });
    let last = rows[rows.len() - 1];
    let col = |k: usize| rows.iter().map(|r| r[k]).collect::<Vec<f64>>();
    let t = col(0);
    let dev: Vec<f64> = col(3).iter().map(|e| e - e0).collect();
    Plot::new(format!(
        "LJ liquid, {} atoms: E(t) - E(0)",
        system.particle_count()
    ))
    .x_label("t (τ, Lennard-Jones time)")
    .y_label("E(t) − E(0) per atom (ε)")
    .series(Series::line("E - E(0)", &t, &dev))
    .write(out.join("energy_drift.png"))?;
    Ok(Row {
        scene: format!("md: LJ liquid, {n} atoms"),
        backend: md.backend_name(),
        steps: md.steps_done(),
        throughput: n * f64::from(steps) / stepping,
        unit: "atom-steps/s",
        check: format!(
            "|E(t) - E(0)| / N <= {:.1e} over t = {:.0} (spread {:.1e} after t = 0.5)",
            rows.iter().map(|r| (r[3] - e0).abs()).fold(0.0, f64::max),
            last[0],
            hi - lo,
        ),
    })
}
