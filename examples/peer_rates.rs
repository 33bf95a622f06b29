//! Rates of simkit's CPU backends on the workloads of the side-by-side peer comparison
//! (`benches/peers/side_by_side.sh`), one machine-readable line per run:
//!
//! ```text
//! rate=1.234e9 unit=cell-updates/s median_of=3 ...
//! ```
//!
//! Each subcommand builds its system (not timed), runs one untimed warm-up, then times
//! `--reps` runs and prints the rate at the median time. Everything runs on a rayon pool of
//! `--threads` threads.
//!
//! ```text
//! cargo run --release --example peer_rates -- rd --n 512 --steps 2000 --threads 2
//! cargo run --release --example peer_rates -- neighbor --n 1000000 --threads 2
//! cargo run --release --example peer_rates -- neighbor-list --n 1000000 --threads 2
//! cargo run --release --example peer_rates -- lattice-gas --n 16384 --steps 20 --method lut
//! cargo run --release --example peer_rates -- pp-coulomb --n 50000 --precision f64
//! ```
//!
//! - `rd`: Gray–Scott (D_u = 1, D_v = 0.5, F = 0.04, k = 0.06, h = 1, explicit Euler with
//!   dt = 0.1) on a periodic `n x n` grid in f64 or f32; cell updates/s (a cell update = both
//!   species of one cell advanced by one step), and the sums of `u`, `v` and `v^2` over the
//!   final grid (row-major order) for a peer's check.
//! - `neighbor`: `n` uniform random points at number density 1 in a closed cube, cutoff 2.5;
//!   sorted cells, build + count of every pair (rayon); unordered pairs/s.
//! - `neighbor-list`: `n` uniform random points at number density 1 in a periodic cube,
//!   cutoff 2.5, no skin; a half list (each pair stored once, as LAMMPS's binned half list
//!   with `newton on`), rayon; unordered pairs/s. `--kind engine` (default): the list md and
//!   dem rebuild, [`BlockedHalfList`] (counting sort by cell, the positions permuted, the
//!   per-block lists built); `--kind verlet`: [`VerletList`] (sorted cells, lists in the
//!   caller's particle order).
//! - `lattice-gas`: FHP-I on a periodic `n x n` lattice at density 0.3; site updates/s, and
//!   the memory traffic at 2 bytes per site update (one state byte read, one written).
//! - `pp-coulomb`: the source's plasma (normalised units, Debye-length exclusion) with `n`
//!   electrons, one symplectic-Euler step = `n (n - 1)` pair interactions; interactions/s and
//!   GFLOP/s at 20 flops per interaction.

use std::process::ExitCode;
use std::time::Instant;

use clap::{Parser, Subcommand, ValueEnum};
use rand::{RngExt, SeedableRng};
use simkit::backend::{Backend, Error, Result, Simulation};
use simkit::lattice_gas::{Config as LgConfig, CpuMethod, Lattice, LatticeGas};
use simkit::neighbor::{BlockedHalfList, CellGrid, ListKind, SortedCells, VerletList};
use simkit::pp_coulomb::{Config as PpConfig, Integrator, PpCoulomb, Precision, scenes, units};
use simkit::rd::scenes::gray_scott_square;
use simkit::rd::{Config as RdConfig, GrayScott, Rd, Stepping};

/// Times one simkit CPU workload of the side-by-side peer comparison and prints one
/// `rate=... unit=...` line.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Rayon threads
    #[arg(long, global = true, default_value_t = 2)]
    threads: usize,
    /// Timed runs; the rate printed is the one at the median time
    #[arg(long, global = true, default_value_t = 1)]
    reps: usize,
    /// The workload
    #[command(subcommand)]
    command: Command,
}

/// The workloads.
#[derive(Subcommand, Debug)]
enum Command {
    /// Gray–Scott reaction–diffusion on a periodic n x n grid (cell updates/s)
    Rd {
        /// Grid side
        #[arg(long, default_value_t = 512)]
        n: usize,
        /// Steps per timed run
        #[arg(long, default_value_t = 2000)]
        steps: u32,
        /// Floating-point precision
        #[arg(long, value_enum, default_value_t = Prec::F64)]
        precision: Prec,
    },
    /// Sorted cells: build + count every pair within 2.5 of n random points (pairs/s)
    Neighbor {
        /// Number of points
        #[arg(long, default_value_t = 1_000_000)]
        n: usize,
    },
    /// Half list (no skin) of n random points in a periodic cube, cutoff 2.5 (pairs/s)
    NeighborList {
        /// Number of points
        #[arg(long, default_value_t = 1_000_000)]
        n: usize,
        /// Which list
        #[arg(long, value_enum, default_value_t = ListChoice::Engine)]
        kind: ListChoice,
    },
    /// FHP-I lattice gas on a periodic n x n lattice (site updates/s)
    LatticeGas {
        /// Lattice side
        #[arg(long, default_value_t = 16_384)]
        n: usize,
        /// Steps per timed run
        #[arg(long, default_value_t = 20)]
        steps: u32,
        /// CPU method
        #[arg(long, value_enum, default_value_t = Method::Lut)]
        method: Method,
    },
    /// Direct-sum Coulomb force of the source's plasma (pair interactions/s)
    PpCoulomb {
        /// Number of particles
        #[arg(long, default_value_t = 50_000)]
        n: usize,
        /// Steps (force evaluations) per timed run
        #[arg(long, default_value_t = 1)]
        steps: u32,
        /// Floating-point precision
        #[arg(long, value_enum, default_value_t = Prec::F64)]
        precision: Prec,
    },
}

/// Floating-point precision of a run.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum Prec {
    /// Single precision
    F32,
    /// Double precision
    F64,
}

/// The half lists of `neighbor-list`.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum ListChoice {
    /// `BlockedHalfList`: sort, permute, build (md's and dem's list)
    Engine,
    /// `VerletList` from sorted cells
    Verlet,
}

/// Lattice-gas CPU method.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum Method {
    /// Lookup table (one byte per site)
    Lut,
    /// Multi-spin coding (bit-planes)
    Multispin,
    /// The library's automatic choice
    Auto,
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    if args.threads == 0 || args.reps == 0 {
        return Err(Error::invalid(
            "--threads / --reps",
            0,
            "must be at least 1",
        ));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
        .map_err(|e| Error::invalid("--threads", args.threads, e.to_string()))?;
    pool.install(|| match args.command {
        Command::Rd {
            n,
            steps,
            precision,
        } => match precision {
            Prec::F64 => rd::<f64>(args, n, steps, "f64"),
            Prec::F32 => rd::<f32>(args, n, steps, "f32"),
        },
        Command::Neighbor { n } => neighbor(args, n),
        Command::NeighborList { n, kind } => neighbor_list(args, n, kind),
        Command::LatticeGas { n, steps, method } => lattice_gas(args, n, steps, method),
        Command::PpCoulomb {
            n,
            steps,
            precision,
        } => pp_coulomb(args, n, steps, precision),
    })
}

/// Runs `f` once untimed, then `reps` times timed; returns the median time in seconds.
fn median_time(reps: usize, mut f: impl FnMut() -> Result<()>) -> Result<f64> {
    f()?;
    let mut t = Vec::with_capacity(reps);
    for _ in 0..reps {
        let start = Instant::now();
        f()?;
        t.push(start.elapsed().as_secs_f64());
    }
    t.sort_by(f64::total_cmp);
    Ok(t[t.len() / 2])
}

/// Prints the result line: `rate=R unit=U` first, then `key=value` details.
fn report(args: &Args, rate: f64, unit: &str, secs: f64, details: &str) {
    println!(
        "rate={rate:.4e} unit={unit} time_s={secs:.4} median_of={} threads={} {details}",
        args.reps, args.threads
    );
}

fn rd<T: simkit::rd::Real>(args: &Args, n: usize, steps: u32, prec: &str) -> Result<()> {
    let grid = gray_scott_square::<T>(n, 1.0, n / 8, 1)?;
    let model = GrayScott::new(1.0, 0.5, 0.04, 0.06)?;
    let mut sim = Rd::new(
        grid,
        model,
        &RdConfig::new(Stepping::euler(0.1)),
        Backend::Cpu,
    )?;
    let secs = median_time(args.reps, || sim.step(steps))?;
    let rate = (n * n) as f64 * f64::from(steps) / secs;
    let backend = sim.backend_name().replace(' ', "_");
    // Sums over the final fields in row-major order, for a peer that runs the same scene
    // and steps to compare with (after (reps + 1) x steps steps: the warm-up run included).
    let state = sim.state()?;
    let sum =
        |s: usize, f: fn(f64) -> f64| -> f64 { state.field(s).iter().map(|x| f(x.to_f64())).sum() };
    let done = (args.reps as u64 + 1) * u64::from(steps);
    report(
        args,
        rate,
        "cell-updates/s",
        secs,
        &format!(
            "workload=gray-scott-{prec} n={n} steps={steps} backend={backend} \
             steps_done={done} sum_u={:.17e} sum_v={:.17e} sum_vv={:.17e}",
            sum(0, |x| x),
            sum(1, |x| x),
            sum(1, |x| x * x)
        ),
    );
    Ok(())
}

/// The neighbour workloads' cutoff.
const CUTOFF: f64 = 2.5;

/// `n` uniform random points at number density 1 in a cube; returns them and the side.
fn random_points(n: usize) -> (Vec<[f64; 3]>, f64) {
    let side = (n as f64).cbrt();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(42);
    let points = (0..n)
        .map(|_| std::array::from_fn(|_| rng.random::<f64>() * side))
        .collect();
    (points, side)
}

fn neighbor(args: &Args, n: usize) -> Result<()> {
    let (points, side) = random_points(n);
    let grid = CellGrid::new([0.0; 3], [side; 3], [false; 3], CUTOFF)?;
    let mut cells = SortedCells::new(&grid);
    let mut pairs = 0;
    let secs = median_time(args.reps, || {
        cells.build(&points)?;
        pairs = std::hint::black_box(cells.par_pair_count());
        Ok(())
    })?;
    report(
        args,
        pairs as f64 / secs,
        "pairs/s",
        secs,
        &format!("workload=sorted-cells-build+pairs n={n} cutoff={CUTOFF} pairs={pairs}"),
    );
    Ok(())
}

fn neighbor_list(args: &Args, n: usize, kind: ListChoice) -> Result<()> {
    let (points, side) = random_points(n);
    let (secs, pairs, name) = match kind {
        ListChoice::Engine => {
            let mut list =
                BlockedHalfList::<f64, 3>::new([0.0; 3], [side; 3], [true; 3], CUTOFF, n)?;
            let mut sorted = Vec::with_capacity(n);
            let secs = median_time(args.reps, || {
                let order = list.sort(&points)?;
                sorted.clear();
                sorted.extend(order.iter().map(|&k| points[k as usize]));
                list.build(&sorted, true)
            })?;
            (secs, list.pair_count(), "blocked-half-list-sort+build")
        }
        ListChoice::Verlet => {
            let grid = CellGrid::new([0.0; 3], [side; 3], [true; 3], CUTOFF)?;
            let mut list = VerletList::new(&grid, 0.0, ListKind::Half)?;
            let secs = median_time(args.reps, || list.build(&points))?;
            (secs, list.stored_entries(), "half-verlet-list-build")
        }
    };
    report(
        args,
        pairs as f64 / secs,
        "pairs/s",
        secs,
        &format!("workload={name} n={n} cutoff={CUTOFF} periodic pairs={pairs}"),
    );
    Ok(())
}

fn lattice_gas(args: &Args, n: usize, steps: u32, method: Method) -> Result<()> {
    let mut lattice = Lattice::new(n, n)?;
    lattice.fill_random(0.3, 1)?;
    let config = LgConfig {
        cpu: match method {
            Method::Lut => CpuMethod::Lut,
            Method::Multispin => CpuMethod::MultiSpin,
            Method::Auto => CpuMethod::Auto,
        },
        ..LgConfig::default()
    };
    let mut sim = LatticeGas::new(lattice, &config, Backend::Cpu)?;
    let secs = median_time(args.reps, || sim.step(steps))?;
    let rate = (n * n) as f64 * f64::from(steps) / secs;
    // The byte-per-site backends read one state byte and write one per site update.
    let gbs = rate * 2.0 / 1e9;
    let backend = sim.backend_name().replace(' ', "_");
    report(
        args,
        rate,
        "site-updates/s",
        secs,
        &format!(
            "workload=fhp-i n={n} steps={steps} backend={backend} gb_per_s_at_2_bytes={gbs:.3}"
        ),
    );
    Ok(())
}

fn pp_coulomb(args: &Args, n: usize, steps: u32, precision: Prec) -> Result<()> {
    let inputs = units::PhysicalInputs {
        particles: n,
        ..units::PhysicalInputs::source_plasma()
    };
    let (p, law, _) = scenes::plasma_box(&inputs, 1)?;
    let (prec, name) = match precision {
        Prec::F64 => (Precision::F64, "f64"),
        Prec::F32 => (Precision::F32, "f32"),
    };
    let config = PpConfig::new(1.0, law)
        .with_integrator(Integrator::SymplecticEuler)
        .with_precision(prec);
    let mut sim = PpCoulomb::new(p, &config, Backend::Cpu)?;
    let secs = median_time(args.reps, || sim.step(steps))?;
    let rate = sim.interactions_per_step() * f64::from(steps) / secs;
    let gflops = rate * 20.0 / 1e9;
    let backend = sim.backend_name().replace(' ', "_");
    report(
        args,
        rate,
        "interactions/s",
        secs,
        &format!(
            "workload=pp-coulomb-{name} n={n} steps={steps} backend={backend} gflops_at_20={gflops:.2}"
        ),
    );
    Ok(())
}
