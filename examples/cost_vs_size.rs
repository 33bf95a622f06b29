//! Cost against size: the throughput of each crate's CPU backend from problems that fit in
//! the L2 cache to about ten times the L3, one CSV and one plot per crate, with this
//! machine's cache sizes marked on the plot.
//!
//! ```text
//! cargo run --release --example cost_vs_size -- --threads 1,2
//! cargo run --release --example cost_vs_size -- --crates md,rd --max-mib 1024
//! cargo run --release --example cost_vs_size -- --update-docs    # into docs/cost_vs_size/
//! ```
//!
//! Every point runs in a process of its own (the program runs itself with `--one`), so
//! that the memory it reports is that point's alone: the resident set after the timed
//! runs minus the resident set before the system was built (`VmRSS` of
//! `/proc/self/status`), what the plots' x axis shows. The sizes are chosen from an
//! estimate of each workload's bytes per element, doubling from `--min-kib` to
//! `--max-mib` (default: ten times the L3 cache of cpu0, from sysfs, at most a third of
//! the available memory). Each point: the system built (not timed), one untimed warm-up
//! unit (a step, or one list build), then units in batches of at least `--seconds`, the
//! best of 3 batches (1 batch when one takes over 3 s). The whole sweep runs `--sweeps`
//! times (default 3, every crate and size each time, so that the samples of one point lie
//! minutes apart); the plots draw the best sample of each point as the curve and every
//! sample as a dot, so the spread a shared machine adds is in the picture.
//!
//! The workloads, all f64, each a rayon pool of `--threads` threads:
//! - `md`: LAMMPS's `in.lj` liquid (density 0.8442, T = 1.44, r_c = 2.5, dt = 0.005, skin
//!   0.3) on `c^3` FCC cells; atom-steps/s, at least 20 steps per batch (so that the list
//!   rebuilds are in the average).
//! - `dem`: spheres of diameter 1 on a periodic simple-cubic lattice of spacing 0.99 (six
//!   overlapping contacts each: a packed bed), small random velocities, no gravity, the
//!   linear law with tangential history and rotation (restitution 0.5, contact time 2e-3,
//!   mu 0.5), the default dt = t_c / 30; particle-steps/s, at least 20 steps per batch.
//! - `rd`: Gray–Scott on a periodic `n x n` grid (the side-by-side scene), explicit Euler
//!   with dt = 0.1 (the default 4 steps per fused sweep); cell updates/s.
//! - `lattice-gas`: FHP on a periodic `n x n` lattice (`n` a multiple of 64) at density
//!   0.3, the default CPU method; site updates/s.
//! - `neighbor`: the half list md and dem rebuild (`BlockedHalfList`: sort, permute,
//!   build) of uniform random points at density 1 in a periodic cube, cutoff 2.5;
//!   pairs/s.
//! - `pp-coulomb`: the source's plasma, one direct-sum step (`n (n - 1)` interactions);
//!   interactions/s. Its cost grows as `n^2`, so the sweep stops at 2^16 particles (a
//!   step of about five seconds on one core), far short of the L3: the state of any `n`
//!   a direct sum can afford fits in cache.
//!
//! Output: `out/cost_vs_size/<crate>.csv` (sweep, threads, elements, bytes, rate, seconds
//! per batch, units per batch, seconds since the sweep began, the core clock before and
//! after the point from a timed chain of dependent adds) and `<crate>.png`; with
//! `--update-docs` the same files in `docs/cost_vs_size/`.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::Instant;

use clap::{Parser, ValueEnum};
use rand::{RngExt, SeedableRng};
use simkit::backend::{Backend, Error, Result, Simulation};
use simkit::dem::{Config as DemConfig, Dem, Dim, LinearHistory, Particle, Scene as DemScene};
use simkit::lattice_gas::{Config as LgConfig, Lattice, LatticeGas};
use simkit::md::{Config as MdConfig, LennardJones, Md, PairTable, scenes as md_scenes};
use simkit::neighbor::BlockedHalfList;
use simkit::output::csv::write_csv;
use simkit::output::plot::{Plot, Scale, Series, Style};
use simkit::pp_coulomb::{Config as PpConfig, Integrator, PpCoulomb, scenes as pp_scenes, units};
use simkit::rd::scenes::gray_scott_square;
use simkit::rd::{Config as RdConfig, GrayScott, Rd, Stepping};

#[path = "common/machine.rs"]
mod machine;
#[path = "common/progress.rs"]
mod progress;

/// Throughput of each crate's CPU backend against problem size, one plot per crate.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Crates to sweep (comma-separated; default all)
    #[arg(long, value_enum, value_delimiter = ',')]
    crates: Vec<Crate>,
    /// Rayon thread counts (comma-separated), one curve each
    #[arg(long, value_delimiter = ',', default_values_t = [1usize, 2])]
    threads: Vec<usize>,
    /// Smallest memory footprint to aim for (KiB)
    #[arg(long, default_value_t = 128)]
    min_kib: u64,
    /// Largest memory footprint to aim for (MiB; default ten times the L3, at most a
    /// third of the available memory)
    #[arg(long)]
    max_mib: Option<u64>,
    /// Least time of one timed batch (s)
    #[arg(long, default_value_t = 0.2)]
    seconds: f64,
    /// Sweeps over every crate and size; each point plots the best of them
    #[arg(long, default_value_t = 3)]
    sweeps: usize,
    /// Write the CSVs and plots into docs/cost_vs_size/ instead of out/cost_vs_size/
    #[arg(long)]
    update_docs: bool,
    /// Internal: time one point of this crate in this process and print it
    #[arg(long, value_enum, hide = true)]
    one: Option<Crate>,
    /// Internal: the element count of `--one`
    #[arg(long, hide = true, default_value_t = 0)]
    elements: usize,
}

/// The workloads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Crate {
    /// Lennard-Jones liquid (`in.lj`), atom-steps/s
    Md,
    /// Packed bed with tangential history and rotation, particle-steps/s
    Dem,
    /// Gray–Scott reaction–diffusion, cell updates/s
    Rd,
    /// FHP lattice gas, site updates/s
    LatticeGas,
    /// The half list md and dem rebuild, pairs/s
    Neighbor,
    /// Direct-sum Coulomb, interactions/s
    PpCoulomb,
}

impl Crate {
    const ALL: [Crate; 6] = [
        Crate::Md,
        Crate::Dem,
        Crate::Rd,
        Crate::LatticeGas,
        Crate::Neighbor,
        Crate::PpCoulomb,
    ];

    /// The name on the command line and in file names.
    fn name(self) -> &'static str {
        match self {
            Crate::Md => "md",
            Crate::Dem => "dem",
            Crate::Rd => "rd",
            Crate::LatticeGas => "lattice-gas",
            Crate::Neighbor => "neighbor",
            Crate::PpCoulomb => "pp-coulomb",
        }
    }

    /// What an element is, and the throughput's unit.
    fn units(self) -> (&'static str, &'static str) {
        match self {
            Crate::Md => ("atoms", "atom-steps/s"),
            Crate::Dem => ("particles", "particle-steps/s"),
            Crate::Rd => ("cells", "cell updates/s"),
            Crate::LatticeGas => ("sites", "site updates/s"),
            Crate::Neighbor => ("points", "pairs/s"),
            Crate::PpCoulomb => ("particles", "interactions/s"),
        }
    }

    /// Estimated bytes per element (only used to choose the sizes; the plots show the
    /// measured footprint) and the largest element count worth running.
    fn estimate(self) -> (f64, usize) {
        match self {
            Crate::Md => (900.0, usize::MAX),
            Crate::Dem => (1000.0, usize::MAX),
            Crate::Rd => (64.0, usize::MAX),
            Crate::LatticeGas => (2.0, usize::MAX),
            Crate::Neighbor => (190.0, usize::MAX),
            Crate::PpCoulomb => (270.0, 1 << 16),
        }
    }
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    if args.threads.is_empty() || args.threads.contains(&0) {
        return Err(Error::invalid(
            "--threads",
            format!("{:?}", args.threads),
            "give one or more thread counts of at least 1",
        ));
    }
    if args.sweeps == 0 {
        return Err(Error::invalid("--sweeps", 0, "give at least one sweep"));
    }
    if !(args.seconds.is_finite() && args.seconds > 0.0) {
        return Err(Error::invalid(
            "--seconds",
            args.seconds,
            "must be positive",
        ));
    }
    if let Some(krate) = args.one {
        let threads = args.threads[0];
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| Error::invalid("--threads", threads, e.to_string()))?;
        let point = pool.install(|| one_point(krate, args.elements, args.seconds))?;
        println!(
            "elements={} bytes={} rate={:.6e} batch_s={:.4} units={} ghz_before={:.3} \
             ghz_after={:.3}",
            point.elements,
            point.bytes,
            point.rate,
            point.batch_s,
            point.units,
            point.ghz[0],
            point.ghz[1]
        );
        return Ok(());
    }
    sweep(args)
}

/// One measured point.
#[derive(Clone, Copy, Debug)]
struct Point {
    /// Elements of the system (atoms, cells, ...).
    elements: usize,
    /// Resident memory the system added (bytes).
    bytes: u64,
    /// Throughput, in the crate's unit.
    rate: f64,
    /// Seconds of one timed batch.
    batch_s: f64,
    /// Units (steps or builds) per batch.
    units: u32,
    /// The core's clock before and after the point (GHz; [`core_ghz`]).
    ghz: [f64; 2],
}

/// The value of `key` (e.g. `VmRSS:`) in a `/proc` file of `key value kB` lines, in bytes.
fn proc_bytes(path: &str, key: &str) -> Option<u64> {
    std::fs::read_to_string(path).ok().and_then(|s| {
        s.lines()
            .find_map(|l| l.strip_prefix(key))
            .and_then(|v| v.trim().strip_suffix("kB"))
            .and_then(|v| v.trim().parse::<u64>().ok())
            .map(|kib| kib * 1024)
    })
}

/// The resident set of this process in bytes (`VmRSS` of `/proc/self/status`).
fn resident_bytes() -> Result<u64> {
    proc_bytes("/proc/self/status", "VmRSS:").ok_or_else(|| {
        Error::invalid(
            "/proc/self/status",
            "no readable VmRSS line",
            "the memory footprint is read from Linux's /proc",
        )
    })
}

/// Times `run(units)`: one untimed unit, then batches of at least `seconds` (and at least
/// `min_units` units); returns the units per batch and the shortest batch time (a shared
/// machine only ever slows a batch down).
fn time_batches(
    seconds: f64,
    min_units: u32,
    mut run: impl FnMut(u32) -> Result<()>,
) -> Result<(u32, f64)> {
    let start = Instant::now();
    run(1)?;
    let one = start.elapsed().as_secs_f64().max(1e-9);
    let units = ((seconds / one).ceil().min(1e6) as u32).max(min_units);
    let batches = if one * f64::from(units) > 3.0 { 1 } else { 3 };
    let mut times = Vec::with_capacity(batches);
    for _ in 0..batches {
        let start = Instant::now();
        run(units)?;
        times.push(start.elapsed().as_secs_f64());
    }
    Ok((units, times.iter().copied().fold(f64::INFINITY, f64::min)))
}

/// Builds and times one point of `krate` with about `elements` elements.
fn one_point(krate: Crate, elements: usize, seconds: f64) -> Result<Point> {
    let before = resident_bytes()?;
    let ghz_before = core_ghz(0.02);
    // Each arm ends with this while its system is alive (its memory still resident):
    // elements, work per unit in the rate's unit, and (units per batch, batch time).
    let point = |elements: usize, work: f64, (units, batch_s): (u32, f64)| -> Result<Point> {
        Ok(Point {
            elements,
            bytes: resident_bytes()?.saturating_sub(before),
            rate: work * f64::from(units) / batch_s,
            batch_s,
            units,
            ghz: [ghz_before, core_ghz(0.02)],
        })
    };
    match krate {
        Crate::Md => {
            let cells = ((elements as f64 / 4.0).cbrt().round() as usize).max(3);
            let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
            let system = md_scenes::fcc_lattice([cells; 3], 0.8442, 1.44, table, &[0], 87287)?;
            let config = MdConfig {
                dt: Some(0.005),
                ..MdConfig::default()
            };
            let mut sim = Md::new(system, &config, Backend::Cpu)?;
            let n = sim.system().particle_count();
            point(n, n as f64, time_batches(seconds, 20, |k| sim.step(k))?)
        }
        Crate::Dem => {
            let side = ((elements as f64).cbrt().round() as usize).max(5);
            let mut sim = Dem::new(packed_bed(side)?, &DemConfig::default(), Backend::Cpu)?;
            let n = side * side * side;
            point(n, n as f64, time_batches(seconds, 20, |k| sim.step(k))?)
        }
        Crate::Rd => {
            let side = ((elements as f64).sqrt().round() as usize).max(32);
            let grid = gray_scott_square::<f64>(side, 1.0, side / 8, 1)?;
            let model = GrayScott::new(1.0, 0.5, 0.04, 0.06)?;
            let config = RdConfig::new(Stepping::euler(0.1));
            let mut sim = Rd::new(grid, model, &config, Backend::Cpu)?;
            let n = side * side;
            point(n, n as f64, time_batches(seconds, 4, |k| sim.step(k))?)
        }
        Crate::LatticeGas => {
            let side = ((elements as f64).sqrt() / 64.0).round().max(1.0) as usize * 64;
            let mut lattice = Lattice::new(side, side)?;
            lattice.fill_random(0.3, 1)?;
            let mut sim = LatticeGas::new(lattice, &LgConfig::default(), Backend::Cpu)?;
            let n = side * side;
            point(n, n as f64, time_batches(seconds, 2, |k| sim.step(k))?)
        }
        Crate::Neighbor => {
            let n = elements.max(1000);
            let side = (n as f64).cbrt();
            let mut rng = rand_pcg::Pcg64::seed_from_u64(42);
            let points: Vec<[f64; 3]> = (0..n)
                .map(|_| std::array::from_fn(|_| rng.random::<f64>() * side))
                .collect();
            let mut list = BlockedHalfList::<f64, 3>::new([0.0; 3], [side; 3], [true; 3], 2.5, n)?;
            let mut sorted = Vec::with_capacity(n);
            let timing = time_batches(seconds, 1, |k| {
                for _ in 0..k {
                    let order = list.sort(&points)?;
                    sorted.clear();
                    sorted.extend(order.iter().map(|&i| points[i as usize]));
                    list.build(&sorted, true)?;
                }
                Ok(())
            })?;
            point(n, list.pair_count() as f64, timing)
        }
        Crate::PpCoulomb => {
            let inputs = units::PhysicalInputs {
                particles: elements.max(256),
                ..units::PhysicalInputs::source_plasma()
            };
            let (p, law, _) = pp_scenes::plasma_box(&inputs, 1)?;
            let config = PpConfig::new(1.0, law).with_integrator(Integrator::SymplecticEuler);
            let mut sim = PpCoulomb::new(p, &config, Backend::Cpu)?;
            let timing = time_batches(seconds, 1, |k| sim.step(k))?;
            point(inputs.particles, sim.interactions_per_step(), timing)
        }
    }
}

/// The clock of the core this runs on (GHz), from a timed chain of dependent register adds
/// (one cycle each): a shared machine's clock drifts with its neighbours' load, and the
/// points record it before and after their batches. NaN off x86-64.
fn core_ghz(seconds: f64) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        let (mut x, one) = (0u64, 1u64);
        let start = Instant::now();
        let mut adds = 0u64;
        while start.elapsed().as_secs_f64() < seconds {
            for _ in 0..10_000 {
                // SAFETY: register arithmetic only, no memory or flags the compiler relies on.
                unsafe {
                    std::arch::asm!(
                        ".rept 64", "add {x}, {one}", ".endr",
                        x = inout(reg) x, one = in(reg) one, options(nomem, nostack)
                    );
                }
            }
            adds += 640_000;
        }
        let ghz = adds as f64 / start.elapsed().as_secs_f64() / 1e9;
        if x == adds { ghz } else { f64::NAN }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = seconds;
        f64::NAN
    }
}

/// The packed bed of the `dem` workload: `side^3` spheres (diameter 1, density 1) on a
/// periodic simple-cubic lattice of spacing 0.99, velocities uniform in [-0.1, 0.1].
fn packed_bed(side: usize) -> Result<DemScene<LinearHistory>> {
    let spacing = 0.99;
    let len = side as f64 * spacing;
    let mass = std::f64::consts::PI / 6.0;
    let law = LinearHistory::new(0.5, 2e-3, 0.5);
    let mut scene = DemScene::new(Dim::Three, [0.0; 3], [len; 3], law)?;
    scene.set_periodic([true; 3]).set_rotation(true);
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    for z in 0..side {
        for y in 0..side {
            for x in 0..side {
                let p = [x, y, z].map(|i| (i as f64 + 0.5) * spacing);
                let v: [f64; 3] = std::array::from_fn(|_| rng.random_range(-0.1..0.1));
                scene.add_particle(Particle::new(p, 0.5, mass).with_velocity(v))?;
            }
        }
    }
    Ok(scene)
}

/// Cache sizes of cpu0 from sysfs: `(name, bytes, shared by how many CPUs)` for the data
/// and unified caches, smallest first.
fn caches() -> Vec<(String, u64, usize)> {
    let mut out = Vec::new();
    for index in 0..8 {
        let dir = PathBuf::from(format!("/sys/devices/system/cpu/cpu0/cache/index{index}"));
        let read = |f: &str| std::fs::read_to_string(dir.join(f)).map(|s| s.trim().to_string());
        let (Ok(level), Ok(kind), Ok(size)) = (read("level"), read("type"), read("size")) else {
            continue;
        };
        if kind == "Instruction" {
            continue;
        }
        let bytes = size
            .strip_suffix('K')
            .and_then(|k| k.parse::<u64>().ok())
            .map(|k| k * 1024);
        let shared = read("shared_cpu_list")
            .map(|l| cpu_list_len(&l))
            .unwrap_or(1);
        if let Some(bytes) = bytes {
            out.push((format!("L{level}"), bytes, shared));
        }
    }
    out.sort_by_key(|c| c.1);
    out
}

/// The number of CPUs in a sysfs list such as `0-3,8`.
fn cpu_list_len(list: &str) -> usize {
    list.split(',')
        .map(|part| match part.split_once('-') {
            Some((a, b)) => match (a.parse::<usize>(), b.parse::<usize>()) {
                (Ok(a), Ok(b)) if b >= a => b - a + 1,
                _ => 1,
            },
            None => 1,
        })
        .sum::<usize>()
        .max(1)
}

/// Available memory in bytes (`MemAvailable` of /proc/meminfo), if known.
fn available_bytes() -> Option<u64> {
    proc_bytes("/proc/meminfo", "MemAvailable:")
}

/// A human size: `512 KiB`, `2 MiB`, `1.5 GiB`.
fn human(bytes: f64) -> String {
    const MIB: f64 = 1024.0 * 1024.0;
    if bytes >= 1024.0 * MIB {
        format!("{:.3} GiB", bytes / (1024.0 * MIB))
    } else if bytes >= MIB {
        format!("{:.3} MiB", bytes / MIB)
    } else {
        format!("{:.0} KiB", bytes / 1024.0)
    }
}

/// Runs every point of every crate in its own process and writes the CSVs and plots.
fn sweep(args: &Args) -> Result<()> {
    let caches = caches();
    let cpu = machine::cpu_model().unwrap_or_else(|| "unknown CPU".to_string());
    let l3 = caches.last().map_or(64 << 20, |c| c.1);
    let limit = available_bytes().map_or(u64::MAX, |a| a / 3);
    let max_bytes = args
        .max_mib
        .map_or(10 * l3, |m| m.saturating_mul(1 << 20))
        .min(limit);
    let min_bytes = args.min_kib.saturating_mul(1024).max(1024);
    if min_bytes >= max_bytes {
        return Err(Error::invalid(
            "--min-kib / --max-mib",
            format!("{} .. {}", human(min_bytes as f64), human(max_bytes as f64)),
            "the smallest footprint must be below the largest (and the largest below a third \
             of the available memory)",
        ));
    }
    let crates = if args.crates.is_empty() {
        Crate::ALL.to_vec()
    } else {
        args.crates.clone()
    };
    let dir = PathBuf::from(if args.update_docs {
        "docs/cost_vs_size"
    } else {
        "out/cost_vs_size"
    });
    std::fs::create_dir_all(&dir)
        .map_err(|e| Error::invalid("output folder", dir.display(), e.to_string()))?;
    let cache_text: Vec<String> = caches
        .iter()
        .map(|(name, bytes, shared)| {
            format!("{name} {} (shared by {shared})", human(*bytes as f64))
        })
        .collect();
    println!("{cpu}; {}", cache_text.join(", "));
    println!(
        "footprints {} .. {}, threads {:?}",
        human(min_bytes as f64),
        human(max_bytes as f64),
        args.threads
    );
    let started = Instant::now();
    let exe = std::env::current_exe()
        .map_err(|e| Error::invalid("current executable", "unknown", e.to_string()))?;
    // Every sweep runs every crate before the next begins, sizes outside and thread counts
    // inside: a slow spell of the machine (a neighbour on the host) then falls on every
    // curve at the same sizes, and the sweeps of one point lie minutes apart.
    let plan: Vec<(Crate, Vec<usize>)> = crates
        .iter()
        .map(|&krate| (krate, sizes(krate, min_bytes, max_bytes)))
        .collect();
    let points: usize = plan.iter().map(|(_, s)| s.len()).sum();
    let bar = progress::bar(
        "cost vs size",
        (points * args.threads.len() * args.sweeps) as u64,
        "points",
    );
    let mut rows: Vec<Vec<[f64; 10]>> = vec![Vec::new(); plan.len()];
    for sweep in 0..args.sweeps {
        for ((krate, sizes), rows) in plan.iter().zip(&mut rows) {
            let mut last = vec![None; args.threads.len()];
            for &n in sizes {
                for (k, &threads) in args.threads.iter().enumerate() {
                    let point = run_child(&exe, *krate, n, threads, args.seconds)?;
                    bar.inc(1);
                    if last[k] == Some(point.elements) {
                        continue;
                    }
                    last[k] = Some(point.elements);
                    bar.suspend(|| {
                        println!(
                            "sweep {} {:<12} {threads} thr {:>11} {:<9} {:>12}  {:.4e} {} \
                             ({:.2}-{:.2} GHz)",
                            sweep + 1,
                            krate.name(),
                            point.elements,
                            krate.units().0,
                            human(point.bytes as f64),
                            point.rate,
                            krate.units().1,
                            point.ghz[0],
                            point.ghz[1]
                        );
                    });
                    rows.push([
                        (sweep + 1) as f64,
                        threads as f64,
                        point.elements as f64,
                        point.bytes as f64,
                        point.rate,
                        point.batch_s,
                        f64::from(point.units),
                        started.elapsed().as_secs_f64(),
                        point.ghz[0],
                        point.ghz[1],
                    ]);
                }
            }
        }
    }
    bar.finish_and_clear();
    for ((krate, _), rows) in plan.iter().zip(&rows) {
        write_csv(
            dir.join(format!("{}.csv", krate.name())),
            &[
                "sweep",
                "threads",
                "elements",
                "bytes",
                "rate",
                "batch_s",
                "units_per_batch",
                "since_start_s",
                "ghz_before",
                "ghz_after",
            ],
            rows,
        )?;
        plot(&dir, *krate, rows, &caches, &cpu, &args.threads)?;
    }
    println!("written to {}/", dir.display());
    Ok(())
}

/// The element counts of `krate`'s points: footprints doubling from `min_bytes` to
/// `max_bytes` by the crate's estimate of bytes per element, up to its largest count.
fn sizes(krate: Crate, min_bytes: u64, max_bytes: u64) -> Vec<usize> {
    let (per, most) = krate.estimate();
    let mut sizes: Vec<usize> = Vec::new();
    let mut target = min_bytes as f64;
    while target <= max_bytes as f64 * 1.0001 {
        let n = ((target / per).round() as usize).clamp(1, most);
        if sizes.last() != Some(&n) {
            sizes.push(n);
        }
        target *= 2.0;
    }
    sizes
}

/// Runs one point in a child process and parses its line.
fn run_child(exe: &Path, krate: Crate, n: usize, threads: usize, seconds: f64) -> Result<Point> {
    let out = Command::new(exe)
        .args([
            "--one",
            krate.name(),
            "--elements",
            &n.to_string(),
            "--threads",
            &threads.to_string(),
            "--seconds",
            &seconds.to_string(),
        ])
        .output()
        .map_err(|e| Error::invalid("child process", exe.display(), e.to_string()))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        return Err(Error::invalid(
            format!("{} point of {n} elements", krate.name()),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim().to_string(),
        ));
    }
    let field = |key: &str| -> Option<f64> {
        stdout
            .split_whitespace()
            .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('='))
            .and_then(|v| v.parse::<f64>().ok())
    };
    match (
        field("elements"),
        field("bytes"),
        field("rate"),
        field("batch_s"),
        field("units"),
    ) {
        (Some(e), Some(b), Some(r), Some(t), Some(u)) => Ok(Point {
            elements: e as usize,
            bytes: b as u64,
            rate: r,
            batch_s: t,
            units: u as u32,
            ghz: [
                field("ghz_before").unwrap_or(f64::NAN),
                field("ghz_after").unwrap_or(f64::NAN),
            ],
        }),
        _ => Err(Error::invalid(
            "child output",
            stdout.trim(),
            "expected elements= bytes= rate= batch_s= units=",
        )),
    }
}

/// Throughput against footprint: per thread count the best sample of each size as a curve
/// and every sample as a dot; the caches as vertical lines.
fn plot(
    dir: &Path,
    krate: Crate,
    rows: &[[f64; 10]],
    caches: &[(String, u64, usize)],
    cpu: &str,
    threads: &[usize],
) -> Result<()> {
    const MIB: f64 = 1024.0 * 1024.0;
    // Row: sweep, threads, elements, bytes, rate, ...
    let top = rows.iter().map(|r| r[4]).fold(0.0, f64::max) * 1.1;
    let (lo, hi) = rows.iter().fold((f64::MAX, 0.0f64), |(lo, hi), r| {
        (lo.min(r[3] / MIB), hi.max(r[3] / MIB))
    });
    let mut plot = Plot::new(format!(
        "{}: CPU throughput against memory footprint ({cpu})",
        krate.name()
    ))
    .size(1000, 560)
    .x_label("memory footprint (MiB, resident)")
    .y_label(krate.units().1)
    .x_scale(Scale::Log10)
    .y_range(0.0, top.max(1.0));
    for (k, &t) in threads.iter().enumerate() {
        let mine: Vec<&[f64; 10]> = rows
            .iter()
            .filter(|r| r[1] as usize == t && r[3] > 0.0)
            .collect();
        // The best sample of each element count, in increasing size.
        let mut best: Vec<&[f64; 10]> = Vec::new();
        for r in &mine {
            match best.iter_mut().find(|b| b[2] == r[2]) {
                Some(b) if b[4] < r[4] => *b = r,
                Some(_) => {}
                None => best.push(r),
            }
        }
        best.sort_by(|a, b| a[2].total_cmp(&b[2]));
        if best.is_empty() {
            continue;
        }
        let colour = THREAD_COLOURS[k % THREAD_COLOURS.len()];
        let (x, y): (Vec<f64>, Vec<f64>) = mine.iter().map(|r| (r[3] / MIB, r[4])).unzip();
        plot.push(
            Series::points("", &x, &y)
                .color(colour.map(|c| (u16::from(c) + 2 * 255).div_ceil(3) as u8)),
        );
        let (x, y): (Vec<f64>, Vec<f64>) = best.iter().map(|r| (r[3] / MIB, r[4])).unzip();
        let name = if t == 1 {
            "1 thread, best of the sweeps".to_string()
        } else {
            format!("{t} threads, best of the sweeps")
        };
        plot.push(
            Series::line(name, &x, &y)
                .style(Style::LinePoints)
                .color(colour),
        );
    }
    for (k, (name, bytes, shared)) in caches.iter().enumerate() {
        let x = *bytes as f64 / MIB;
        if x < lo * 0.5 || x > hi * 2.0 {
            continue;
        }
        let per = if *shared > 1 {
            format!("shared by {shared} CPUs")
        } else {
            "per core".to_string()
        };
        plot.push(
            Series::line(
                format!("{name} {} ({per})", human(*bytes as f64)),
                &[x, x],
                &[0.0, top],
            )
            .color(CACHE_COLOURS[k % CACHE_COLOURS.len()]),
        );
    }
    plot.write(dir.join(format!("{}.png", krate.name())))
}

/// Colours of the thread counts' curves (their samples: the same, lighter).
const THREAD_COLOURS: [[u8; 3]; 4] = [
    [31, 119, 180],
    [230, 100, 10],
    [44, 160, 44],
    [148, 103, 189],
];

/// Colours of the cache-size markers.
const CACHE_COLOURS: [[u8; 3]; 4] = [[150, 150, 150], [110, 110, 110], [70, 70, 70], [30, 30, 30]];
