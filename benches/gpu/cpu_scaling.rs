//! Each crate's CPU path on 1, 2, 4, 8, ... rayon threads (up to the machine's), within a
//! time budget: how the CPU backends scale past the two cores of our CI machines.

use std::fmt::Write as _;

use rand::{RngExt, SeedableRng};
use simkit::backend::{Backend, Precision, Result, Simulation};
use simkit::neighbor::{CellGrid, SortedCells};
use simkit::{dem, lattice_gas, md, pp_coulomb, rd};

use crate::{Timing, rate_of, si};

/// The CPU's model name from `/proc/cpuinfo` (or `unknown`).
pub fn cpu_model() -> String {
    crate::machine::cpu_model().unwrap_or_else(|| "unknown".into())
}

/// A case: name, unit, and a function that builds the run and returns `(work per step,
/// stepper)`; built and stepped inside the thread pool being measured.
type Stepper = Box<dyn FnMut(u32) -> Result<()>>;
type Case = (
    String,
    &'static str,
    Box<dyn Fn() -> Result<(f64, Stepper)> + Send + Sync>,
);

fn cases(quick: bool) -> Vec<Case> {
    let pick = |full: usize, small: usize| if quick { small } else { full };
    let mut v: Vec<Case> = Vec::new();
    let cells = pick(20, 6);
    v.push((
        format!("md in.lj {} f64", 4 * cells * cells * cells),
        "atom-steps/s",
        Box::new(move || {
            let table = md::PairTable::uniform(1, md::LennardJones::new(1.0, 1.0, 2.5))?;
            let system = md::scenes::fcc_lattice([cells; 3], 0.8442, 1.44, table, &[0], 87287)?;
            let n = system.particle_count() as f64;
            let mut sim = md::Md::new(system, &md::Config::default().with_dt(0.005), Backend::Cpu)?;
            Ok((n, Box::new(move |k| sim.step(k)) as Stepper))
        }),
    ));
    let (nx, nz) = (pick(25, 8), pick(32, 8));
    v.push((
        format!("dem box {} f64", nx * nx * nz),
        "particle-steps/s",
        Box::new(move || {
            let scene = dem::scenes::granular_box(nx, nx, nz, 4_928_459)?;
            let n = scene.particles().len() as f64;
            let mut sim =
                dem::Dem::new(scene, &dem::Config::default().with_dt(1e-4), Backend::Cpu)?;
            Ok((n, Box::new(move |k| sim.step(k)) as Stepper))
        }),
    ));
    let n = pick(4096, 256);
    v.push((
        format!("lattice-gas {n}^2"),
        "site-updates/s",
        Box::new(move || {
            let mut lattice = lattice_gas::Lattice::new(n, n)?;
            lattice.fill_random(0.3, 1)?;
            let mut sim = lattice_gas::LatticeGas::new(
                lattice,
                &lattice_gas::Config::default(),
                Backend::Cpu,
            )?;
            Ok(((n * n) as f64, Box::new(move |k| sim.step(k)) as Stepper))
        }),
    ));
    let n = pick(2048, 128);
    v.push((
        format!("rd gray-scott {n}^2 f32"),
        "cell-updates/s",
        Box::new(move || {
            let grid = rd::scenes::gray_scott_square::<f32>(n, 1.0, n / 8, 1)?;
            let model = rd::GrayScott::new(1.0, 0.5, 0.04, 0.06)?;
            let config = rd::Config::new(rd::Stepping::euler(0.1));
            let mut sim = rd::Rd::new(grid, model, &config, Backend::Cpu)?;
            Ok(((n * n) as f64, Box::new(move |k| sim.step(k)) as Stepper))
        }),
    ));
    let n = pick(16_384, 1024);
    v.push((
        format!("pp-coulomb {n} f32"),
        "interactions/s",
        Box::new(move || {
            use pp_coulomb::Config;
            let (p, law) = crate::rows::plasma(n)?;
            let config = Config::new(1.0, law).with_precision(Precision::F32);
            let mut sim = pp_coulomb::PpCoulomb::new(p, &config, Backend::Cpu)?;
            Ok((
                n as f64 * (n as f64 - 1.0),
                Box::new(move |k| sim.step(k)) as Stepper,
            ))
        }),
    ));
    let n = pick(1_000_000, 10_000);
    v.push((
        format!("neighbor sorted cells {n}"),
        "pairs/s",
        Box::new(move || {
            let side = (n as f64).cbrt();
            let mut rng = rand_pcg::Pcg64::seed_from_u64(42);
            let p: Vec<[f64; 3]> = (0..n)
                .map(|_| std::array::from_fn(|_| rng.random::<f64>() * side))
                .collect();
            let grid = CellGrid::new([0.0; 3], [side; 3], [false; 3], 2.5)?;
            let mut cells = SortedCells::new(&grid);
            cells.build(&p)?;
            let pairs = cells.par_pair_count() as f64;
            Ok((
                pairs,
                Box::new(move |k: u32| {
                    for _ in 0..k {
                        cells.build(&p)?;
                        std::hint::black_box(cells.par_pair_count());
                    }
                    Ok(())
                }) as Stepper,
            ))
        }),
    ));
    v
}

/// The thread-scaling table (markdown) within about `seconds`.
pub fn run(quick: bool, seconds: f64) -> String {
    let max = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads: Vec<usize> = [1usize, 2, 4, 8, 16, 32, 64]
        .into_iter()
        .filter(|&t| t <= max)
        .collect();
    let cases = cases(quick);
    // Per cell: one warm-up, one calibration and three samples.
    let per_cell = seconds / (cases.len() * threads.len()) as f64;
    let timing = Timing {
        sample_seconds: per_cell / 6.0,
        samples: 3,
    };
    let mut s = format!(
        "## CPU paths over rayon threads ({})\n\n| case |",
        cpu_model()
    );
    for t in &threads {
        let _ = write!(s, " {t} |");
    }
    s.push_str(" speed-up |\n|---|");
    s.push_str(&"---|".repeat(threads.len() + 1));
    s.push('\n');
    for (name, unit, build) in &cases {
        let _ = write!(s, "| {name} ({unit}) |");
        let mut first = None;
        let mut last = None;
        for &t in &threads {
            let cell = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .map_err(|e| e.to_string())
                .and_then(|pool| {
                    pool.install(|| -> Result<f64> {
                        let (work, mut step) = build()?;
                        let (k, samples) = timing.time(&mut step)?;
                        Ok(rate_of(work * f64::from(k), &samples))
                    })
                    .map_err(|e| e.to_string())
                });
            match cell {
                Ok(r) => {
                    first.get_or_insert(r);
                    last = Some(r);
                    let _ = write!(s, " {} |", si(r, ""));
                }
                Err(e) => {
                    let _ = write!(s, " error: {e} |");
                }
            }
        }
        match (first, last) {
            (Some(a), Some(b)) => {
                let _ = writeln!(s, " {:.1}x |", b / a);
            }
            _ => s.push_str(" |\n"),
        }
        eprintln!("cpu scaling: {name} done");
    }
    s.push('\n');
    s
}
