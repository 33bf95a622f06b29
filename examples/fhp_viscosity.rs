//! FHP shear viscosity from the decay of a sinusoidal shear wave, against the FHP-I theory
//! `nu(d) = 1/(12 d (1-d)^3) - 1/8`, for FHP-I and the full collision table.
//!
//! ```text
//! cargo run --release --example fhp_viscosity [-- WIDTH HEIGHT RUNS]
//! ```
//! Defaults: 8192 x 80 sites (wavelength 69 lattice units), 8 runs (seeds) per density,
//! averaged. Environment overrides: `SKIP` (steps before the fit, 30), `STOP` (fit until the
//! amplitude falls to this fraction, 0.3), `AMP` (velocity amplitude, 0.1). The measured
//! viscosity grows slowly with the wavelength (the logarithmic long-time-tail renormalisation
//! of 2D lattice gases), so compare at several heights: see docs/lattice-gas.md.
//!
//! ```text
//! cargo run --release --example fhp_viscosity -- --tradeoffs
//! ```
//! runs the trade-off sweep of docs/tradeoffs/lattice-gas.md instead: velocity noise of
//! block- and time-averaged fields in a 1024 x 1024 box at rest (d = 0.3) against block size
//! and averaging window, with the time each costs; writes `out/fhp_tradeoffs/noise.png`.

use std::time::Instant;

use simkit::backend::Simulation;
use simkit::lattice_gas::observables::{BlockField, TimeAverage};
use simkit::lattice_gas::viscosity::{ShearWave, fhp1_viscosity};
use simkit::lattice_gas::{Config, Lattice, MultiSpinCpu, ROW_SPACING, RuleSet};
use simkit::output::plot::{Plot, Scale, Series, Style};

fn main() -> simkit::backend::Result<()> {
    if std::env::args().any(|a| a == "--tradeoffs") {
        return tradeoffs();
    }
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let width = args.first().copied().unwrap_or(8192);
    let height = args.get(1).copied().unwrap_or(80);
    let runs = args.get(2).copied().unwrap_or(8).max(1);
    println!(
        "shear-wave viscosity, {width} x {height} sites, {runs} runs per point (multi-spin CPU)\n"
    );
    println!(
        "{:<8} {:>6} {:>12} {:>10} {:>12} {:>9} {:>8}",
        "rules", "d", "nu measured", "+- (sem)", "nu FHP-I th", "error %", "time s"
    );
    for rules in [RuleSet::FhpI, RuleSet::Full] {
        for d in [0.15, 0.2, 0.3, 0.4, 0.5] {
            let t = Instant::now();
            let mut values = Vec::new();
            for seed in 0..runs as u32 {
                // About 20 samples over the expected FHP-I decay, at most every 10 steps.
                let k = std::f64::consts::TAU / (height as f64 * ROW_SPACING);
                let decay_steps = (1.0 / 0.3f64).ln() / (fhp1_viscosity(d) * k * k);
                let wave = ShearWave {
                    rules,
                    sample_every: (decay_steps / 20.0).clamp(1.0, 10.0) as u32,
                    seed: seed + 1,
                    skip: env_or("SKIP", 30.0) as u32,
                    stop_fraction: env_or("STOP", 0.3),
                    amplitude: env_or("AMP", 0.1),
                    ..ShearWave::new(width, height, d)
                };
                values.push(wave.measure()?.viscosity);
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
            println!(
                "{label:<8} {d:>6.2} {mean:>12.4} {sem:>10.4} {theory:>12.4} {:>9.2} {:>8.2}",
                100.0 * (mean / theory - 1.0),
                t.elapsed().as_secs_f64()
            );
        }
    }
    Ok(())
}

fn env_or(name: &str, default: f64) -> f64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Velocity noise of block- and time-averaged fields at rest against block size and window.
fn tradeoffs() -> simkit::backend::Result<()> {
    let (n, d, gap) = (1024usize, 0.3, 10u32);
    let blocks = [4usize, 8, 16, 32, 64];
    let windows = [1usize, 4, 16, 64];
    let mut lattice = Lattice::new(n, n)?;
    lattice.fill_random(d, 5)?;
    let mut sim = MultiSpinCpu::new(lattice, &Config::default())?;
    sim.step(50)?;
    let max_window = *windows.last().expect("windows");
    let mut snapshots = Vec::with_capacity(max_window);
    let t = Instant::now();
    for _ in 0..max_window {
        sim.step(gap)?;
        snapshots.push(sim.state()?);
    }
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
    let mut plot = Plot::new("FHP-I noise at rest, 1024^2, d = 0.3")
        .x_label("block side b (sites)")
        .y_label("rms block velocity")
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
    plot.write("out/fhp_tradeoffs/noise.png")?;
    println!("\nwrote out/fhp_tradeoffs/noise.png");
    Ok(())
}
