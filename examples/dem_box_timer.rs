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
//! 32 as the deck; `dem_gran3d.lmp -var nx X -var ny Y -var nz Z` is the same box). Prints
//! particle-steps/s.
//! `benches/peers/dem_vs_lammps.sh STEPS` runs it next to LAMMPS.

use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, Result, Simulation};
use simkit::dem::scenes::granular_box;
use simkit::dem::{Config, Dem};

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
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let steps = args.steps;
    let scene = granular_box(args.nx, args.ny, args.nz, 4_928_459)?;
    let n = scene.particles().len();
    let mut sim = Dem::new(scene, &Config::default(), Backend::Cpu)?;
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
        "{}: N = {n}, {steps} steps in {secs:.2} s: {rate:.3e} particle-steps/s",
        sim.backend_name()
    );
    Ok(())
}
