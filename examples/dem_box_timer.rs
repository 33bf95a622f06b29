//! Times one long run of the LAMMPS comparison box: the 3D granular box of
//! `benches/peers/dem_gran3d.lmp` (N = 20,000) on the CPU backend (f64) from the initial
//! state, construction not timed (the progress bar splits the run into `step` calls of at
//! least 100 steps). The criterion bench times the deck's 2000 steps; this covers longer windows,
//! where the pile has settled and every grain has several contacts.
//!
//! ```text
//! RAYON_NUM_THREADS=2 cargo run --release --example dem_box_timer -- --steps 30000
//! ```
//! Options: `--steps N` (steps to time, 2000), `--nx`, `--ny`, `--nz` (the lattice, 25 x 25 x
//! 32 as the deck; `dem_gran3d.lmp -var nx X -var ny Y -var nz Z` is the same box),
//! `--model viscous` (the default: the linear law with viscous Coulomb-capped friction and
//! no rotation, `scenes::granular_box`) or `--model history` (rotation and a tangential
//! spring per contact, `scenes::granular_box_history`: the physics of the deck's
//! `-var model hooke/history`). The time step is the deck's, 1e-4. Prints
//! particle-steps/s.
//! `benches/peers/dem_vs_lammps.sh STEPS` runs it next to LAMMPS.

use std::process::ExitCode;
use std::time::Instant;

use clap::{Parser, ValueEnum};
use simkit::backend::{Backend, Result, Simulation};
use simkit::dem::scenes::{granular_box, granular_box_history};
use simkit::dem::{Config, ContactLaw, Dem, Scene};

#[path = "common/progress.rs"]
mod progress;

/// Times the LAMMPS comparison granular box (N = 20,000, CPU f64) and prints
/// particle-steps/s.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Steps to time, from the initial state
    #[arg(long, value_name = "N", default_value_t = 2000)]
    steps: u32,
    /// Lattice sites along x (the deck's `-var nx`)
    #[arg(long, default_value_t = 25)]
    nx: usize,
    /// Lattice sites along y (the deck's `-var ny`)
    #[arg(long, default_value_t = 25)]
    ny: usize,
    /// Lattice sites along z, layers (the deck's `-var nz`)
    #[arg(long, default_value_t = 32)]
    nz: usize,
    /// The contact model
    #[arg(long, value_enum, default_value_t = Model::Viscous)]
    model: Model,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Model {
    /// Linear law, viscous Coulomb-capped friction, no rotation (LAMMPS `gran/hooke`
    /// without its rotation).
    Viscous,
    /// Linear law with rotation and tangential springs (LAMMPS `gran/hooke/history` with
    /// `nve/sphere`).
    History,
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let seed = 4_928_459;
    match args.model {
        Model::Viscous => time(granular_box(args.nx, args.ny, args.nz, seed)?, args.steps),
        Model::History => time(
            granular_box_history(args.nx, args.ny, args.nz, seed)?,
            args.steps,
        ),
    }
}

fn time<L: ContactLaw>(scene: Scene<L>, steps: u32) -> Result<()> {
    let n = scene.particles().len();
    let mut sim = Dem::new(scene, &Config::default().with_dt(1e-4), Backend::Cpu)?;
    // The bar advances in pieces of at least 100 steps (one `step` call each, aligned with
    // the blow-up check's interval; the state is the same as with one call).
    let bar = progress::bar("dem box", u64::from(steps), "steps");
    let chunk = (steps / 100).max(100);
    let start = Instant::now();
    while sim.steps_done() < u64::from(steps) {
        let k = chunk.min(steps - sim.steps_done() as u32);
        sim.step(k)?;
        bar.inc(u64::from(k));
    }
    let secs = start.elapsed().as_secs_f64();
    bar.finish();
    let rate = n as f64 * f64::from(steps) / secs;
    println!(
        "{} {}: N = {n}, {steps} steps in {secs:.2} s: {rate:.3e} particle-steps/s",
        sim.backend_name(),
        L::NAME
    );
    Ok(())
}
