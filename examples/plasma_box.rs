//! The source's plasma box from its physical inputs: 50,000 electrons at 10 eV in a
//! 64 x 1e-4 m box at n0 = 5e16 m^-3, time step 1.5e-11 s, normalised to k_e = 1 and dt = 1,
//! with the near-field exclusion radius equal to the Debye length and the source's
//! symplectic Euler update (but with double-buffered positions and zero-mean velocities).
//!
//! ```text
//! cargo run --release --example plasma_box                        # 10 steps, CPU f64
//! cargo run --release --example plasma_box -- --steps 50 --f32
//! cargo run --release --example plasma_box -- --gpu --n 16384
//! cargo run --release --example plasma_box -- --steps 20 --checkpoint-every 10
//! cargo run --release --example plasma_box -- --steps 40 --resume out/plasma_box/checkpoint.ckpt
//! ```
//! Prints the normalised units, interactions/s and the energy before and after (for a
//! resumed run: at the resumed step and at the end). `--checkpoint-every N` saves the run
//! every N steps to `out/plasma_box/checkpoint.ckpt`; `--resume FILE` continues it up to
//! `--steps` in total, bit for bit as the uninterrupted run. Options: `--steps N` (10),
//! `--n N` (macro-particles, 50,000), `--f32` (single precision; f64 by default), `--gpu`,
//! `--checkpoint-every N`, `--resume FILE`.

use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, GpuContext, Result, Simulation};
use simkit::pp_coulomb::units::PhysicalInputs;
use simkit::pp_coulomb::{Config, Integrator, PpCoulomb, Precision, scenes};

#[path = "common/checkpoint.rs"]
mod checkpoint;
#[path = "common/progress.rs"]
mod progress;

/// The source's plasma box from its physical inputs (electrons at 10 eV, n0 = 5e16 m^-3,
/// dt = 1.5e-11 s, exclusion radius = Debye length): interactions/s and the energy change.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Total time steps of 1.5e-11 s (a resumed run continues up to this many)
    #[arg(long, value_name = "N", default_value_t = 10)]
    steps: u32,
    /// Number of macro-particles (electrons; the box and density stay the source's)
    #[arg(long, value_name = "N", default_value_t = PhysicalInputs::source_plasma().particles)]
    n: usize,
    /// Single precision (f32) instead of f64
    #[arg(long)]
    f32: bool,
    /// Run on the GPU backend instead of the CPU
    #[arg(long)]
    gpu: bool,
    #[command(flatten)]
    checkpoint: checkpoint::CheckpointArgs,
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let steps = args.steps;
    let mut inputs = PhysicalInputs::source_plasma();
    inputs.particles = args.n;
    let precision = if args.f32 {
        Precision::F32
    } else {
        Precision::F64
    };
    let ctx = if args.gpu {
        Some(GpuContext::new()?)
    } else {
        None
    };
    let backend = ctx.as_ref().map_or(Backend::Cpu, Backend::Gpu);

    let (particles, law, u) = scenes::plasma_box(&inputs, 12345)?;
    println!("physical inputs: {inputs:?}");
    println!(
        "normalised units: w = {:.0}, L = {:.7e} m, T = {:e} s, V = {:.4e} m/s",
        u.weight, u.length, u.time, u.velocity
    );
    println!(
        "normalised: box {:.10}, thermal speed {:.10}, Debye length {:.8}, omega_pe dt {:.4}",
        u.box_length, u.thermal_speed, u.debye_length, u.omega_pe_dt
    );
    let config = Config::new(1.0, law)
        .with_integrator(Integrator::SymplecticEuler)
        .with_precision(precision);
    let checkpoints = args
        .checkpoint
        .checkpoints(std::path::Path::new("out/plasma_box"));
    let mut sim = checkpoints.start(backend, |b| PpCoulomb::new(particles, &config, b))?;
    let first = u32::try_from(sim.steps_done())
        .unwrap_or(u32::MAX)
        .min(steps);
    let steps = steps - first;
    println!(
        "{} particles, exclusion radius {:.4} (Debye length), {steps} steps on {}",
        sim.len(),
        u.debye_length,
        sim.backend_name()
    );
    let d0 = sim.diagnostics()?;
    let bar = progress::bar("plasma box", u64::from(steps), "steps");
    let start = Instant::now();
    for _ in 0..steps {
        checkpoints.step(&mut sim, 1)?;
        bar.inc(1);
    }
    // GPU work is asynchronous: the state download waits for it.
    let _ = sim.state()?;
    let elapsed = start.elapsed().as_secs_f64();
    bar.finish();
    let d1 = sim.diagnostics()?;
    let rate = sim.interactions_per_step() * f64::from(steps) / elapsed.max(1e-12);
    println!(
        "{steps} steps in {elapsed:.2} s: {:.3} s/step, {rate:.3e} pair interactions/s",
        elapsed / f64::from(steps.max(1))
    );
    for (name, d) in [("initial", d0), ("final", d1)] {
        println!(
            "{name:>7}: kinetic {:.6e}, potential {:.6e}, total {:.6e}, |momentum| {:.2e}, \
             |sum of forces| / sum |F| {:.1e}",
            d.kinetic,
            d.potential,
            d.total,
            (d.momentum.iter().map(|c| c * c).sum::<f64>()).sqrt(),
            (d.force_sum.iter().map(|c| c * c).sum::<f64>()).sqrt() / d.force_magnitude_sum
        );
    }
    println!(
        "relative energy change {:.3e} (the exclusion cut-off makes the force \
         non-conservative at r = Debye length; see docs/pp-coulomb.md)",
        (d1.total - d0.total) / d0.total.abs()
    );
    Ok(())
}
