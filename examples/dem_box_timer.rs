//! Times one long run of the LAMMPS comparison box: the 3D granular box of
//! `benches/peers/dem_gran3d.lmp` (N = 20,000) on the CPU backend (f64), one `step(n)`
//! call from the initial state, construction not timed. The criterion bench times the
//! deck's 2000 steps; this covers longer windows, where the pile has settled and every
//! grain has several contacts.
//!
//! ```text
//! RAYON_NUM_THREADS=2 cargo run --release --example dem_box_timer -- --steps 30000
//! ```
//! Prints particle-steps/s. `benches/peers/dem_vs_lammps.sh STEPS` runs it next to LAMMPS.

use std::time::Instant;

use simkit::backend::{Backend, Result, Simulation};
use simkit::dem::scenes::granular_box;
use simkit::dem::{Config, Dem};

fn main() -> Result<()> {
    let steps: u32 = simkit::cli::arg("--steps", 2000)?;
    let scene = granular_box(25, 25, 32, 4_928_459)?;
    let n = scene.particles().len();
    let mut sim = Dem::new(&scene, &Config::default(), Backend::Cpu)?;
    let start = Instant::now();
    sim.step(steps)?;
    let secs = start.elapsed().as_secs_f64();
    let rate = n as f64 * f64::from(steps) / secs;
    println!(
        "{}: N = {n}, {steps} steps in {secs:.2} s: {rate:.3e} particle-steps/s",
        sim.backend_name()
    );
    Ok(())
}
