//! FHP shear viscosity from the decay of a sinusoidal shear wave, against the FHP-I theory
//! `nu(d) = 1/(12 d (1-d)^3) - 1/8`, for FHP-I and the full collision table.
//!
//! ```text
//! cargo run --release --example fhp_viscosity [-- --width W --height H --runs R]
//! ```
//! Options (defaults): `--width` 8192 and `--height` 80 sites (wavelength 69 lattice units),
//! `--runs` 8 (seeds per density, averaged), `--skip` (steps before the fit, 30), `--stop`
//! (fit until the amplitude falls to this fraction, 0.3), `--amp` (velocity amplitude,
//! 0.1). The measured
//! viscosity grows slowly with the wavelength (the logarithmic long-time-tail renormalisation
//! of 2D lattice gases), so compare at several heights: see docs/lattice-gas.md.
//!
//! ```text
//! cargo run --release --example fhp_viscosity -- --tradeoffs
//! ```
//! runs the trade-off sweep of docs/tradeoffs/lattice-gas.md instead: velocity noise of
//! block- and time-averaged fields in a 1024 x 1024 box at rest (d = 0.3) against block size
//! and averaging window, with the time each costs; prints the table and writes
//! `out/fhp_viscosity/noise.png`, or `docs/tradeoffs/lattice-gas.png` (the tracked plot) with
//! `--tradeoffs --update-docs`.

use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, Result, Simulation};
use simkit::lattice_gas::{BlockField, TimeAverage};
use simkit::lattice_gas::{Config, CpuMethod, Lattice, LatticeGas, ROW_SPACING, RuleSet};
use simkit::lattice_gas::{ShearWave, fhp1_viscosity};
use simkit::output::plot::{Plot, Scale, Series, Style};

#[path = "common/progress.rs"]
mod progress;
#[path = "common/tradeoffs.rs"]
mod tradeoffs;

/// FHP shear viscosity from the decay of a shear wave against the FHP-I theory, for FHP-I
/// and the full collision table (multi-spin CPU); or, with --tradeoffs, the noise sweep.
#[derive(Parser, Debug)]
#[command(version, allow_negative_numbers = true)]
struct Args {
    /// Lattice width in sites
    #[arg(long, value_name = "SITES", default_value_t = 8192)]
    width: usize,
    /// Lattice height in rows (one wavelength of the shear wave)
    #[arg(long, value_name = "ROWS", default_value_t = 80)]
    height: usize,
    /// Runs (seeds) per density, averaged
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..))]
    runs: u32,
    /// Steps before the fit starts
    #[arg(long, value_name = "STEPS", default_value_t = 30)]
    skip: u32,
    /// Fit until the wave amplitude has fallen to this fraction of its start
    #[arg(long, value_name = "FRACTION", default_value_t = 0.3)]
    stop: f64,
    /// Initial velocity amplitude of the wave (lattice units per step)
    #[arg(long, default_value_t = 0.1)]
    amp: f64,
    /// Run the block-size / averaging-window noise sweep instead (1024 x 1024 at rest)
    #[arg(long)]
    tradeoffs: bool,
    /// With --tradeoffs: write the plot to docs/tradeoffs/lattice-gas.png (the tracked
    /// documentation) instead of out/fhp_viscosity/noise.png
    #[arg(long, requires = "tradeoffs")]
    update_docs: bool,
}

fn main() -> ExitCode {
    let args = Args::parse();
    simkit::cli::exit_code(if args.tradeoffs {
        noise_sweep(&tradeoffs::TradeoffArgs {
            update_docs: args.update_docs,
        })
    } else {
        run(&args)
    })
}

fn run(args: &Args) -> Result<()> {
    let (width, height, runs) = (args.width, args.height, args.runs);
    println!(
        "shear-wave viscosity, {width} x {height} sites, {runs} runs per point (multi-spin CPU)\n"
    );
    println!(
        "{:<8} {:>6} {:>12} {:>10} {:>12} {:>9} {:>8}",
        "rules", "d", "nu measured", "+- (sem)", "nu FHP-I th", "error %", "time s"
    );
    let densities = [0.15, 0.2, 0.3, 0.4, 0.5];
    let bar = progress::bar(
        "shear waves",
        2 * densities.len() as u64 * u64::from(runs),
        "runs",
    );
    for rules in [RuleSet::FhpI, RuleSet::Full] {
        for d in densities {
            let t = Instant::now();
            let mut values = Vec::new();
            for seed in 0..runs {
                // About 20 samples over the expected FHP-I decay, at most every 10 steps.
                let k = std::f64::consts::TAU / (height as f64 * ROW_SPACING);
                let decay_steps = (1.0 / 0.3f64).ln() / (fhp1_viscosity(d) * k * k);
                let wave = ShearWave {
                    rules,
                    sample_every: (decay_steps / 20.0).clamp(1.0, 10.0) as u32,
                    seed: seed + 1,
                    skip: args.skip,
                    stop_fraction: args.stop,
                    amplitude: args.amp,
                    ..ShearWave::new(width, height, d)
                };
                values.push(wave.measure()?.viscosity);
                bar.inc(1);
            }
            let n = values.len() as f64;
            let mean = values.iter().sum::<f64>() / n;
            let sem = if values.len() > 1 {
                (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt()
            } else {
                f64::NAN
            };
            let theory = fhp1_viscosity(d);
            let label = match rules {
                RuleSet::FhpI => "FHP-I",
                RuleSet::Full => "full",
            };
            let secs = t.elapsed().as_secs_f64();
            bar.suspend(|| {
                println!(
                    "{label:<8} {d:>6.2} {mean:>12.4} {sem:>10.4} {theory:>12.4} {:>9.2} {secs:>8.2}",
                    100.0 * (mean / theory - 1.0),
                );
            });
        }
    }
    bar.finish();
    Ok(())
}

/// Velocity noise of block- and time-averaged fields at rest against block size and window.
fn noise_sweep(out: &tradeoffs::TradeoffArgs) -> Result<()> {
    let (n, d, gap) = (1024usize, 0.3, 10u32);
    let blocks = [4usize, 8, 16, 32, 64];
    let windows = [1usize, 4, 16, 64];
    let mut lattice = Lattice::new(n, n)?;
    lattice.fill_random(d, 5)?;
    let multispin = Config {
        cpu: CpuMethod::MultiSpin,
        ..Config::default()
    };
    let mut sim = LatticeGas::new(lattice, &multispin, Backend::Cpu)?;
    sim.step(50)?;
    let max_window = *windows.last().expect("windows");
    let mut snapshots = Vec::with_capacity(max_window);
    let bar = progress::bar("snapshots", max_window as u64, "samples");
    let t = Instant::now();
    for _ in 0..max_window {
        sim.step(gap)?;
        snapshots.push(sim.state()?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    // Stepping plus the bit-plane to byte conversion, per sample.
    let per_sample = t.elapsed().as_secs_f64() / max_window as f64;
    println!(
        "velocity noise at rest, {n} x {n}, d = {d}, samples {gap} steps apart, multi-spin CPU"
    );
    println!(
        "(one sample: {gap} steps + snapshot = {:.1} ms)\n",
        1e3 * per_sample
    );
    println!(
        "{:>6} {:>7} {:>12} {:>14} {:>14}",
        "block", "window", "rms u_x", "rms * b sqrt(T)", "time/field ms"
    );
    let mut plot = Plot::new("FHP-I noise at rest, 1024², d = 0.3")
        .x_label("block side b (sites)")
        .y_label("rms block velocity (lattice units per step)")
        .x_scale(Scale::Log10)
        .y_scale(Scale::Log10);
    for &window in &windows {
        let mut noise = Vec::new();
        for &b in &blocks {
            let t = Instant::now();
            let mut avg = TimeAverage::new();
            for snap in &snapshots[..window] {
                avg.add(&BlockField::from_lattice(snap, b)?)?;
            }
            let averaging = t.elapsed().as_secs_f64();
            let (ux, _) = avg.field().expect("samples").velocity();
            let rms = (ux.iter().map(|u| u * u).sum::<f64>() / ux.len() as f64).sqrt();
            let cost = averaging + per_sample * window as f64;
            println!(
                "{b:>6} {window:>7} {rms:>12.5} {:>14.4} {:>14.1}",
                rms * b as f64 * (window as f64).sqrt(),
                1e3 * cost
            );
            noise.push(rms);
        }
        plot.push(
            Series::line(
                format!("window {window} samples"),
                &blocks.map(|b| b as f64),
                &noise,
            )
            .style(Style::LinePoints),
        );
    }
    // The block sums straight from the bit-planes vs snapshot + byte block sums.
    let reps = 10;
    let t = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(sim.block_field(16)?);
    }
    let planes_ms = 1e3 * t.elapsed().as_secs_f64() / f64::from(reps);
    let t = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(BlockField::from_lattice(&sim.state()?, 16)?);
    }
    let bytes_ms = 1e3 * t.elapsed().as_secs_f64() / f64::from(reps);
    println!(
        "\none 16x16 block field: {planes_ms:.2} ms from the bit-planes, {bytes_ms:.2} ms via a byte snapshot"
    );
    let path = out.dir("fhp_viscosity").join(if out.update_docs {
        "lattice-gas.png"
    } else {
        "noise.png"
    });
    plot.write(&path)?;
    println!("\nwrote {}", path.display());
    Ok(())
}
