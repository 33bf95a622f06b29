//! LAMMPS's `in.lj` benchmark system: a Lennard-Jones liquid of 32 000 atoms (`20^3` FCC
//! cells at density 0.8442, started at T = 1.44, cutoff 2.5, skin 0.3, dt = 0.005) run at
//! constant energy. Prints the throughput in atom-steps/s, the energy per atom, pressure
//! and temperature at the start and the end, and the energy drift.
//!
//! ```text
//! cargo run --release --example lj_fluid [-- --cells N --steps N --thermo-every N
//!     --dt DT --shift --gpu --f32] [--checkpoint-every N] [--resume out/lj_fluid/checkpoint.ckpt]
//! ```
//! Defaults: 20 cells per side (32 000 atoms, the `in.lj` system), 1000 steps, thermo
//! output every 100 steps, the CPU backend in `f64`, energies not shifted (as `in.lj`).
//! `--cells N` runs `N^3` cells (`4 N^3` atoms, N >= 3); `--gpu` runs on the GPU backend
//! (`f32`), `--f32` the CPU backend in `f32`. `--checkpoint-every N` saves the run every N
//! steps; `--resume FILE` continues a saved run up to `--steps` in total (the printed
//! "start" values are then those of the resumed state). `--help` lists them.
//!
//! The throughput counts the time spent in `step` only (not the thermo output or the
//! files), like LAMMPS's "Loop time". Temperatures are `2 K / (3 N - 3)`, the convention of
//! LAMMPS's `thermo` output.
//!
//! Output under `out/lj_fluid/`:
//! - `thermo.csv`: step, time, temperature, pair energy, kinetic and total energy per
//!   atom, pressure, every `--thermo-every` steps;
//! - `traj.gsd` (GSD, HOOMD-blue's format, for OVITO, freud, MDAnalysis): a frame at every
//!   thermo row (positions relative to the box centre, velocities, type `Ar`, diameter
//!   sigma, mass); a resumed run continues it from its checkpoint's step;
//! - `final.xyz` (extended XYZ: argon, velocities, radii, box) and `final.vtp` (VTK poly data
//!   for ParaView and OVITO): the last state; the radius is sigma / 2.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, Error, GpuContext, Precision, Result, Simulation};
use simkit::md::{Config, Diagnostics, LennardJones, Md, PairTable, State, System, scenes};
use simkit::output::csv::CsvWriter;
use simkit::output::gsd::{GsdFrame, GsdWriter};
use simkit::output::vtk::Particles;
use simkit::output::xyz::{XyzFrame, write_xyz};

#[path = "common/checkpoint.rs"]
mod checkpoint;
#[path = "common/progress.rs"]
mod progress;

/// Density of `in.lj` (reduced units, atoms per sigma^3).
const DENSITY: f64 = 0.8442;
/// Initial temperature of `in.lj`.
const TEMPERATURE: f64 = 1.44;
/// Cutoff of `in.lj`.
const CUTOFF: f64 = 2.5;
/// Velocity seed of `in.lj` (the seed `lj_melt` uses).
const SEED: u64 = 87287;

/// LAMMPS's in.lj Lennard-Jones liquid at constant energy: throughput, thermo CSV, XYZ/VTK
/// snapshot under out/lj_fluid/.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// FCC unit cells per side (4 N^3 atoms; 20 = the 32,000 atoms of in.lj; at least 3)
    #[arg(long, value_name = "N", default_value_t = 20)]
    cells: usize,
    /// Total steps of the run (a resumed run continues up to this many)
    #[arg(long, value_name = "N", default_value_t = 1000)]
    steps: u32,
    /// Thermo output (CSV row) every N steps (0: start and end only)
    #[arg(long, value_name = "N", default_value_t = 100)]
    thermo_every: u32,
    /// Time step in reduced units (in.lj: 0.005)
    #[arg(long, value_name = "DT", default_value_t = 0.005)]
    dt: f64,
    /// Shift every pair energy by phi(r_c) (continuous energy; in.lj does not)
    #[arg(long)]
    shift: bool,
    /// Run on the GPU backend (f32) instead of the CPU
    #[arg(long)]
    gpu: bool,
    /// Run the CPU backend in f32 instead of f64
    #[arg(long, conflicts_with = "gpu")]
    f32: bool,
    #[command(flatten)]
    checkpoint: checkpoint::CheckpointArgs,
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

/// The `in.lj` system with `cells^3` FCC cells (`scenes::lj_melt` for 20).
fn system(cells: usize) -> Result<System> {
    if cells < 3 {
        return Err(Error::invalid(
            "--cells",
            cells,
            "need at least 3 (the periodic box must be twice the cutoff 2.5 long)",
        ));
    }
    if cells == 20 {
        return scenes::lj_melt();
    }
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, CUTOFF))?;
    scenes::fcc_lattice([cells; 3], DENSITY, TEMPERATURE, table, &[0], SEED)
}

/// One thermo line: temperature `2 K / (3 N - 3)`, energies per atom, pressure.
#[derive(Clone, Copy)]
struct Thermo {
    step: u64,
    time: f64,
    temperature: f64,
    pair: f64,
    kinetic: f64,
    total: f64,
    pressure: f64,
}

impl Thermo {
    fn new(step: u64, d: &Diagnostics, n: usize) -> Self {
        let dof = (3 * n).saturating_sub(3).max(1) as f64;
        let n = n as f64;
        Self {
            step,
            time: d.time,
            temperature: 2.0 * d.kinetic / dof,
            pair: d.potential / n,
            kinetic: d.kinetic / n,
            total: d.total / n,
            pressure: d.pressure,
        }
    }

    fn row(&self) -> [f64; 7] {
        [
            self.step as f64,
            self.time,
            self.temperature,
            self.pair,
            self.kinetic,
            self.total,
            self.pressure,
        ]
    }

    fn print(&self, label: &str) {
        println!(
            "{label:<6} step {:>7}  T {:.6}  E_pair/N {:.6}  E/N {:.8}  P {:.6}",
            self.step, self.temperature, self.pair, self.total, self.pressure
        );
    }
}

fn run(args: &Args) -> Result<()> {
    if args.steps == 0 {
        return Err(Error::invalid("--steps", 0, "give at least one step"));
    }
    let ctx = if args.gpu {
        Some(GpuContext::new()?)
    } else {
        None
    };
    let backend = ctx.as_ref().map_or(Backend::Cpu, Backend::Gpu);
    let out = PathBuf::from("out/lj_fluid");
    let checkpoints = args.checkpoint.checkpoints(&out);
    let config = Config {
        dt: Some(args.dt),
        precision: if args.f32 {
            Precision::F32
        } else {
            Precision::F64
        },
        shift: args.shift,
        ..Config::default()
    };
    let mut md = checkpoints.start(backend, |backend| {
        Md::new(system(args.cells)?, &config, backend)
    })?;
    let n = md.system().particle_count();
    let total = u64::from(args.steps);
    let first = md.steps_done().min(total);
    println!(
        "in.lj Lennard-Jones liquid: {n} atoms, density {DENSITY}, cutoff {CUTOFF}, skin {}, \
         dt {}, {} steps on {}; output in {}/",
        md.config().skin,
        md.dt(),
        total - first,
        md.backend_name(),
        out.display()
    );
    let mut csv = CsvWriter::create(
        out.join("thermo.csv"),
        &[
            "step",
            "time",
            "temperature",
            "pair_energy_per_atom",
            "kinetic_energy_per_atom",
            "total_energy_per_atom",
            "pressure",
        ],
    )?;
    let start = Thermo::new(first, &md.diagnostics()?, n);
    start.print("start");
    csv.row(&start.row())?;
    // A resumed run rewrites its first frame and drops those written after its checkpoint.
    let traj_path = out.join("traj.gsd");
    let mut traj = if first > 0 && traj_path.exists() {
        GsdWriter::resume(&traj_path, first - 1)?
    } else {
        // f32 frames (hoomd schema 1.4): every GSD reader opens them.
        GsdWriter::create(&traj_path, Precision::F32)?
    };
    traj.push(&gsd_frame(first, &mut md)?)?;
    let every = if args.thermo_every == 0 {
        total
    } else {
        u64::from(args.thermo_every)
    };
    let bar = progress::bar("lj_fluid", total, "steps");
    bar.set_position(first);
    bar.reset_eta();
    let mut stepping = 0.0;
    let mut done = first;
    let mut end = start;
    while done < total {
        // Thermo rows at multiples of `every` of the whole run (a resumed run too).
        let chunk = (every - done % every).min(total - done);
        let n_steps = u32::try_from(chunk).unwrap_or(u32::MAX);
        let t = Instant::now();
        checkpoints.step(&mut md, n_steps)?;
        stepping += t.elapsed().as_secs_f64();
        done += u64::from(n_steps);
        bar.inc(u64::from(n_steps));
        end = Thermo::new(done, &md.diagnostics()?, n);
        csv.row(&end.row())?;
        traj.push(&gsd_frame(done, &mut md)?)?;
    }
    bar.finish();
    csv.finish()?;
    end.print("end");
    let rate = n as f64 * (done - first) as f64 / stepping;
    println!(
        "energy drift: (E_end - E_start) / N = {:.3e} ({:.3e} relative) over t = {:.3}",
        end.total - start.total,
        (end.total - start.total) / start.total.abs(),
        end.time - start.time
    );
    println!(
        "{rate:.4e} atom-steps/s ({} steps in {stepping:.3} s of stepping, {})",
        done - first,
        md.backend_name()
    );
    write_snapshot(&md.state()?, &md, &out)?;
    println!(
        "wrote {0}/thermo.csv, {0}/traj.gsd, {0}/final.xyz, {0}/final.vtp",
        out.display()
    );
    Ok(())
}

/// The state at `step` as a GSD frame: type `Ar`, diameter sigma, the species' mass.
fn gsd_frame(step: u64, md: &mut Md) -> Result<GsdFrame> {
    let state = md.state()?;
    let system = md.system();
    let (lo, len) = (system.lo(), system.lengths());
    let hi = [lo[0] + len[0], lo[1] + len[1], lo[2] + len[2]];
    let sigma = |s: u32| {
        system
            .table()
            .get(s as usize, s as usize)
            .map_or(1.0, |p| p.sigma)
    };
    let diameters: Vec<f64> = state.species.iter().map(|&s| sigma(s)).collect();
    let masses: Vec<f64> = state
        .species
        .iter()
        .map(|&s| system.masses()[s as usize])
        .collect();
    let mut frame = GsdFrame::from_state(step, &state, &lo, &hi)?;
    frame
        .types(&state.species, &["Ar"])?
        .diameters(&diameters)?
        .masses(&masses)?;
    Ok(frame)
}

/// The last state as extended XYZ (species, positions, velocities, radii, box) and VTK
/// particles; each particle's radius is half its like-pair sigma (the contact distance).
fn write_snapshot(state: &State, md: &Md, out: &std::path::Path) -> Result<()> {
    let len = md.system().lengths();
    let table = md.system().table();
    let radii: Vec<f64> = state
        .species
        .iter()
        .map(|&s| {
            table
                .get(s as usize, s as usize)
                .map_or(0.5, |p| 0.5 * p.sigma)
        })
        .collect();
    let mut frame = XyzFrame::from_xyz(&state.positions)?;
    frame
        .uniform_species("Ar")?
        .lattice([[len[0], 0.0, 0.0], [0.0, len[1], 0.0], [0.0, 0.0, len[2]]])?
        .pbc(md.system().periodic())
        .time(state.time)?;
    frame
        .velocities(state.velocities.as_flattened(), 3)?
        .radii(&radii)?;
    write_xyz(out.join("final.xyz"), &[frame])?;
    let ids: Vec<u32> = (0..state.positions.len() as u32).collect();
    let mut vtp = Particles::from_xyz(&state.positions)?;
    vtp.add_scalar("radius", &radii)?
        .add_ints("id", &ids)?
        .add_vector("Velocity", state.velocities.as_flattened(), 3)?;
    vtp.write(out.join("final.vtp"))
}
