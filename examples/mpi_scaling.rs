//! Strong-scaling driver for the distributed runs: one problem, timed on however many ranks
//! `mpirun` starts (also runs as a single process). Rank 0 prints one line per run:
//! `crate=rd ranks=2 size=4096 steps=100 seconds=1.234 rate=2.7e9 unit=cell-updates/s`.
//!
//! ```text
//! cargo build --release --features mpi --example mpi_scaling
//! RAYON_NUM_THREADS=1 mpirun -np 2 -x RAYON_NUM_THREADS target/release/examples/mpi_scaling rd
//! RAYON_NUM_THREADS=1 mpirun -np 2 -x RAYON_NUM_THREADS target/release/examples/mpi_scaling lattice-gas
//! RAYON_NUM_THREADS=1 mpirun -np 2 -x RAYON_NUM_THREADS target/release/examples/mpi_scaling pp-coulomb
//! RAYON_NUM_THREADS=1 mpirun -np 2 -x RAYON_NUM_THREADS target/release/examples/mpi_scaling dem
//! RAYON_NUM_THREADS=1 mpirun -np 2 -x RAYON_NUM_THREADS target/release/examples/mpi_scaling md
//! mpirun -np 2 target/release/examples/mpi_scaling --steps 20000 comm --size 1024
//! ```
//! `benches/peers/mpi_scaling.sh` alternates 1 and 2 ranks and prints the efficiencies.
//! Problems: `rd` — Gray–Scott f64 (`F = 0.04`, `k = 0.06`, `Du = 1`, `Dv = 0.5`, explicit
//! Euler `dt = 0.2`) on a periodic `size x size` grid seeded with a centre square;
//! `lattice-gas` — FHP-I on a periodic `size x size` lattice at 30 % fill; `pp-coulomb` —
//! the source's electron plasma (normalised units, exclusion law at the Debye length), `n`
//! electrons, f64, symplectic Euler, replicated data (`n (n - 1)` interactions per step);
//! `dem` — the granular pile of the LAMMPS deck (`nx x ny x nz` grains on a lattice of
//! spacing 1.05, periodic x and y, a floor, gravity, friction, `dt = 1e-4`; default
//! 200,000 grains), spatial decomposition along x and y; `md` — LAMMPS's `in.lj` liquid
//! (`cells^3` FCC cells at density 0.8442, T = 1.44, cutoff 2.5, skin 0.3, `dt = 0.005`,
//! f64, velocity Verlet; default 20 cells, 32,000 atoms), spatial decomposition along x and
//! y; `comm` — the communication layer alone: calls per second of `Comm::agree` on a
//! passing check and of a depth-1 halo exchange of two f64 fields on a periodic `size^2`
//! grid (what the agreement adds to each collective call, next to what a call costs).
//! Each run takes a few warm-up steps, then times `steps` steps between barriers.

use std::process::ExitCode;
use std::time::Instant;

use clap::{Parser, Subcommand};
use simkit::backend::Result;
use simkit::backend::Simulation;
use simkit::backend::comm::{CartDecomposition, Comm};
use simkit::dem::scenes::granular_box;
use simkit::dem::{Config as DemConfig, DistributedDem};
use simkit::lattice_gas::{Config as LgConfig, DistributedLatticeGas, Lattice};
use simkit::md::{Config as MdConfig, DistributedMd, LennardJones, PairTable, scenes as md_scenes};
use simkit::pp_coulomb::scenes::plasma_box;
use simkit::pp_coulomb::units::PhysicalInputs;
use simkit::pp_coulomb::{Config as PpConfig, DistributedCoulomb, Integrator};
use simkit::rd::scenes::gray_scott_square;
use simkit::rd::{Config as RdConfig, DistributedRd, GrayScott, Stepping};

/// Times one distributed run on the ranks mpirun started.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Which crate's distributed run
    #[command(subcommand)]
    problem: Problem,
    /// Timed steps
    #[arg(long, value_name = "N", default_value_t = 100, global = true)]
    steps: u32,
    /// Untimed steps before the timing
    #[arg(long, value_name = "N", default_value_t = 5, global = true)]
    warmup: u32,
}

/// The problems.
#[derive(Subcommand, Debug)]
enum Problem {
    /// Gray–Scott f64 on a periodic size^2 grid
    Rd {
        /// Cells per side
        #[arg(long, default_value_t = 4096)]
        size: usize,
    },
    /// FHP-I lattice gas on a periodic size^2 lattice
    LatticeGas {
        /// Sites per side (even: periodic in y)
        #[arg(long, default_value_t = 4096)]
        size: usize,
    },
    /// Granular pile of the LAMMPS deck (3D, periodic x and y, floor, gravity, friction),
    /// spatial decomposition
    Dem {
        /// Lattice sites along x
        #[arg(long, default_value_t = 100)]
        nx: usize,
        /// Lattice sites along y
        #[arg(long, default_value_t = 100)]
        ny: usize,
        /// Lattice sites along z (layers)
        #[arg(long, default_value_t = 20)]
        nz: usize,
    },
    /// LAMMPS's in.lj Lennard-Jones liquid (f64, velocity Verlet), spatial decomposition
    Md {
        /// FCC unit cells per side (4 cells^3 atoms; 20 = the 32,000 atoms of in.lj)
        #[arg(long, default_value_t = 20)]
        cells: usize,
    },
    /// The communication layer's own costs, per call (`steps` calls): `Comm::agree` of a
    /// passing check (the agreement every collective call with a local check adds: one
    /// all-gather of a byte) and a depth-1 halo exchange of two f64 fields on a periodic
    /// size^2 grid (rd's Gray–Scott exchange, agreement included)
    Comm {
        /// Cells per side of the grid whose halo is exchanged
        #[arg(long, default_value_t = 4096)]
        size: usize,
    },
    /// Direct-sum Coulomb (f64) of the source's plasma, replicated data
    PpCoulomb {
        /// Electrons
        #[arg(long, default_value_t = 50_000)]
        n: usize,
    },
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

/// Runs `warmup` steps, then times `steps` steps between barriers with `step`; prints the
/// line on rank 0.
fn time(
    comm: &Comm,
    args: &Args,
    what: &str,
    size: usize,
    per_step: f64,
    unit: &str,
    mut step: impl FnMut(u32) -> Result<()>,
) -> Result<()> {
    step(args.warmup)?;
    comm.barrier();
    let t = Instant::now();
    step(args.steps)?;
    comm.barrier();
    let seconds = t.elapsed().as_secs_f64();
    if comm.is_root() {
        let rate = per_step * f64::from(args.steps) / seconds;
        println!(
            "crate={what} ranks={} size={size} steps={} seconds={seconds:.4} rate={rate:.4e} \
             unit={unit}",
            comm.size(),
            args.steps
        );
    }
    Ok(())
}

fn run(args: &Args) -> Result<()> {
    let comm = Comm::mpi()?;
    match args.problem {
        Problem::Rd { size } => {
            let grid = gray_scott_square::<f64>(size, 1.0, size / 8, 1)?;
            let model = GrayScott::new(1.0, 0.5, 0.04, 0.06)?;
            let config = RdConfig::new(Stepping::euler(0.2));
            let mut run = DistributedRd::new(grid.clone(), model, &config, comm.clone())?;
            drop(grid);
            let cells = (size * size) as f64;
            time(&comm, args, "rd", size, cells, "cell-updates/s", |n| {
                run.step(n)
            })
        }
        Problem::LatticeGas { size } => {
            let mut lattice = Lattice::new(size, size)?;
            lattice.fill_random(0.3, 7)?;
            let mut run =
                DistributedLatticeGas::new(lattice.clone(), &LgConfig::default(), comm.clone())?;
            drop(lattice);
            let sites = (size * size) as f64;
            time(
                &comm,
                args,
                "lattice-gas",
                size,
                sites,
                "site-updates/s",
                |n| run.step(n),
            )
        }
        Problem::Dem { nx, ny, nz } => {
            let scene = granular_box(nx, ny, nz, 1)?;
            let config = DemConfig {
                dt: Some(1e-4),
                ..DemConfig::default()
            };
            let mut run = DistributedDem::new(scene.clone(), &config, comm.clone())?;
            let n = scene.particles().len();
            time(&comm, args, "dem", n, n as f64, "particle-steps/s", |k| {
                run.step(k)
            })
        }
        Problem::Md { cells } => {
            let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
            // The velocity seed of in.lj (the one `scenes::lj_melt` uses).
            let system = md_scenes::fcc_lattice([cells; 3], 0.8442, 1.44, table, &[0], 87287)?;
            let config = MdConfig::default().with_dt(0.005);
            let mut run = DistributedMd::new(system.clone(), &config, comm.clone())?;
            let n = system.particle_count();
            drop(system);
            time(&comm, args, "md", n, n as f64, "atom-steps/s", |k| {
                run.step(k)
            })
        }
        Problem::Comm { size } => {
            time(&comm, args, "comm-agree", size, 1.0, "calls/s", |n| {
                (0..n).try_for_each(|_| comm.agree(Ok(())))
            })?;
            let grid = CartDecomposition::new([size, size], comm.size(), [true, true])?;
            let [nx, ny] = grid.block(comm.rank()).len;
            let mut fields = vec![0.0f64; 2 * (nx + 2) * (ny + 2)];
            time(&comm, args, "comm-halo", size, 1.0, "calls/s", |n| {
                (0..n).try_for_each(|_| grid.exchange_halo(&comm, &mut fields, 1))
            })
        }
        Problem::PpCoulomb { n } => {
            let inputs = PhysicalInputs {
                particles: n,
                ..PhysicalInputs::source_plasma()
            };
            let (particles, law, _) = plasma_box(&inputs, 1)?;
            let config = PpConfig::new(1.0, law).with_integrator(Integrator::SymplecticEuler);
            let mut run = DistributedCoulomb::new(particles, &config, comm.clone())?;
            let pairs = run.interactions_per_step();
            time(&comm, args, "pp-coulomb", n, pairs, "interactions/s", |k| {
                run.step(k)
            })
        }
    }
}
